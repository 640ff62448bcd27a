"""Check the block links of an MDF4 file before asammdf follows them.

asammdf trusts the links: a data-group link that points back to the header made ``import``
loop forever, and a channel link past the end of the file dropped the channel with a
warning only. :func:`check_links` walks the header -> data groups -> channel groups ->
channels chains (and the data lists) itself: every link must be 0 or point inside the file,
to a block of the expected type, and no chain may visit a block twice. Each breach is an
:class:`~vehval.errors.InputFileError` naming the block, the link and the channel.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import BinaryIO

from vehval.errors import InputFileError

#: Header of every MDF4 block: id, reserved, length, link count.
_HEAD = struct.Struct("<4s4xQQ")
#: Most blocks of one kind walked (a real file has thousands of channels at most).
MAX_BLOCKS = 1_000_000
#: Deepest nesting of composed channels (structures of structures) walked.
MAX_COMPOSITION = 16
#: Block types a data group's data link may point to.
_DATA = (b"##DT", b"##DZ", b"##DL", b"##HL", b"##RD", b"##DV", b"##DI", b"##LD", b"##RV",
         b"##RI", b"##SD")
_TEXT = (b"##TX", b"##MD")
_KIND = {b"##DG": "data-group", b"##CG": "channel-group", b"##CN": "channel", b"##DL": "data-list"}


class _Walker:
    def __init__(self, path: Path, fh: BinaryIO, size: int) -> None:
        self.path, self.fh, self.size = path, fh, size
        self.count = 0

    def fail(self, what: str) -> InputFileError:
        return InputFileError(f"{self.path}: corrupted MDF4 file: {what}; the file cannot be "
                              "read safely (export it again from the logger software)")

    def block(self, addr: int, expected: tuple[bytes, ...], where: str) -> list[int]:
        """Links of the block at ``addr`` after checking its place and type."""
        self.count += 1
        if self.count > MAX_BLOCKS:
            raise self.fail(f"more than {MAX_BLOCKS:,} blocks linked")
        if addr < 64 or addr + _HEAD.size > self.size:
            raise self.fail(f"{where} points to byte {addr:,}, outside the file "
                            f"({self.size:,} bytes)")
        self.fh.seek(addr)
        ident, length, nlinks = _HEAD.unpack(self.fh.read(_HEAD.size))
        if ident not in expected:
            want = " or ".join(e.decode()[2:] for e in expected[:3])
            raise self.fail(f"{where} points to byte {addr:,}, a "
                            f"{ident.decode('latin-1')[2:]!r} block where a {want} block is "
                            "expected")
        if length < _HEAD.size + 8 * nlinks or addr + length > self.size:
            raise self.fail(f"the {ident.decode('latin-1')[2:]} block at byte {addr:,} "
                            f"declares {length:,} bytes and {nlinks:,} links, past the end of "
                            "the file")
        raw = self.fh.read(8 * nlinks)
        return list(struct.unpack(f"<{nlinks}Q", raw))

    def text(self, addr: int) -> str:
        """The text of a TX/MD block (for naming a channel); '' when absent or damaged."""
        if not addr:
            return ""
        try:
            links = self.block(addr, _TEXT, "a name link")
            self.fh.seek(addr + 8)
            length = struct.unpack("<Q", self.fh.read(8))[0]
            self.fh.seek(addr + _HEAD.size + 8 * len(links))
            raw = self.fh.read(min(length - _HEAD.size - 8 * len(links), 200))
            return raw.split(b"\0")[0].decode("utf-8", errors="replace")
        except (InputFileError, struct.error):
            return ""

    def link(self, links: list[int], k: int) -> int:
        return links[k] if k < len(links) else 0

    def chain(self, first: int, kind: bytes, where: str, next_link: int = 0):
        """Addresses and links of a linked list of ``kind`` blocks, each visited once."""
        seen: set[int] = set()
        addr, here = first, where
        while addr:
            if addr in seen:
                raise self.fail(f"{here} points back to byte {addr:,}: the "
                                f"{kind.decode()[2:]} blocks form a loop")
            seen.add(addr)
            links = self.block(addr, (kind,), here)
            yield addr, links
            here = f"the next-{_KIND.get(kind, kind.decode()[2:])} link of {self.label(kind, addr, links)}"
            addr = self.link(links, next_link)

    def label(self, kind: bytes, addr: int, links: list[int]) -> str:
        """Words naming a block in a message (a channel by its name)."""
        if kind == b"##CN":
            name = self.text(self.link(links, 2))
            if name:
                return f"channel '{name}'"
        return f"the {_KIND.get(kind, kind.decode()[2:])} block at byte {addr:,}"

    def channels(self, first: int, where: str, gi: int, depth: int = 0) -> None:
        if depth > MAX_COMPOSITION:
            raise self.fail(f"channels of group {gi} nested deeper than {MAX_COMPOSITION}")
        for addr, links in self.chain(first, b"##CN", where):
            label = f"{self.label(b'##CN', addr, links)} (group {gi})"
            for k, what, kinds in ((2, "name", _TEXT), (4, "conversion", (b"##CC",)),
                                   (6, "unit", _TEXT), (7, "comment", _TEXT)):
                target = self.link(links, k)
                if target:
                    self.block(target, kinds, f"the {what} link of {label}")
            comp = self.link(links, 1)
            if comp:
                self.fh.seek(comp)
                ident = self.fh.read(4) if comp + 4 <= self.size else b""
                if ident == b"##CN":
                    self.channels(comp, f"the composition link of {label}", gi, depth + 1)
                else:
                    self.block(comp, (b"##CA",), f"the composition link of {label}")

    def data(self, addr: int, where: str) -> None:
        links = self.block(addr, _DATA, where)
        self.fh.seek(addr)
        ident = self.fh.read(4)
        if ident == b"##HL" and links:
            self.data(links[0], f"the data-list link of the HL block at byte {addr:,}")
        elif ident == b"##DL":
            for dl_addr, dl_links in self.chain(addr, b"##DL", where):
                for blk in dl_links[1:]:
                    if blk:
                        self.block(blk, _DATA, f"a data link of the DL block at byte "
                                               f"{dl_addr:,}")

    def walk(self) -> None:
        hd = self.block(64, (b"##HD",), "the file header")
        for gi, (dg_addr, dg) in enumerate(self.chain(self.link(hd, 0), b"##DG",
                                                      "the header's first-data-group link")):
            for cg_addr, cg in self.chain(self.link(dg, 1), b"##CG",
                                          f"the first-channel-group link of data group {gi}"):
                self.channels(self.link(cg, 1), f"the first-channel link of the channel "
                                                f"group at byte {cg_addr:,} (group {gi})", gi)
            if self.link(dg, 2):
                self.data(self.link(dg, 2), f"the data link of data group {gi}")


def check_links(path: Path) -> None:
    """Validate the block links of an MDF4 file (MDF3 and non-MDF files pass untouched).

    Raises
    ------
    InputFileError
        A link outside the file, to a block of the wrong type, or a loop; the message names
        the link and, for channel links, the channel.
    """
    try:
        with path.open("rb") as fh:
            ident = fh.read(64)
            if not ident.startswith(b"MDF     4") and not ident.startswith(b"UnFinMF 4"):
                return
            fh.seek(0, 2)
            _Walker(path, fh, fh.tell()).walk()
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read ({exc.strerror})") from None
    except struct.error:
        raise InputFileError(f"{path}: corrupted MDF4 file: a block is cut short") from None
