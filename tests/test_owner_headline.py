"""One owner for the headline sentence: vehval.results.headline.

The headline's figure with U and its caveats is written once. A second copy reading the
headline's U (``fuel_economy_u_mpg``) and writing a ``±``/``+-`` figure from it, outside the
owner, fails here; the command line, the report and the workbench call the owner.
"""

import re
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "vehval"
OWNER = SRC / "results" / "headline.py"
#: Writers of the key (not readers forming a sentence): the gate and the batch state it,
#: the catalog stores it as a column.
WRITERS = {SRC / "results" / "gate.py", SRC / "batch" / "task.py", SRC / "catalog.py",
           SRC / "report" / "batch_index.py"}


def test_no_second_headline_formatter():
    bad = []
    for path in SRC.rglob("*.py"):
        if path == OWNER or path in WRITERS:
            continue
        text = path.read_text(encoding="utf-8")
        if "fuel_economy_u_mpg" in text and re.search(r"(±|\+-)", text):
            bad.append(str(path.relative_to(SRC)))
    assert not bad, f"headline formatted outside vehval.results.headline: {bad}"


def test_the_three_consumers_use_the_owner():
    for rel in ("cli/commands_results.py", "report/sections.py", "serve/bench.py"):
        text = (SRC / rel).read_text(encoding="utf-8")
        assert "from vehval.results.headline import headline_of" in text, rel
