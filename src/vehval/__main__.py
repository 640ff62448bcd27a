import sys

from vehval.cli import main

sys.exit(main())
