"""float64 columns between Arrow and numpy without pyarrow's pandas shim.

``pyarrow.Array.to_numpy`` and ``pyarrow.array`` consult pandas (and import it, about
0.3 s, when it is installed) even for a plain float64 column. The readers and the Test
writer only move float64 columns, so they go through the Arrow buffers here: the result is
the same (a null is NaN; NaN stays NaN and is not a null).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pyarrow as pa


def _valid(bitmap, offset: int, n: int) -> np.ndarray:
    """Validity of ``n`` slots from an Arrow bitmap (LSB first) starting at bit ``offset``."""
    first, last = offset // 8, (offset + n + 7) // 8
    bits = np.unpackbits(np.frombuffer(bitmap, np.uint8)[first:last], bitorder="little")
    return bits[offset - 8 * first:offset - 8 * first + n].astype(bool)


def float_values(column: pa.Array | pa.ChunkedArray) -> np.ndarray:
    """A float64 Arrow column as a new, writable numpy array [the column's unit].

    Nulls become NaN, as ``column.to_numpy()`` gives them. A column of another type is
    converted by pyarrow itself.
    """
    import pyarrow as pa

    chunks = column.chunks if isinstance(column, pa.ChunkedArray) else [column]
    if not pa.types.is_float64(column.type):
        return np.asarray(column.to_numpy(), dtype=float)
    out = np.empty(len(column), dtype=np.float64)
    pos = 0
    for chunk in chunks:
        n = len(chunk)
        if n:
            bitmap, data = chunk.buffers()[:2]
            out[pos:pos + n] = np.frombuffer(data, np.float64, count=n, offset=8 * chunk.offset)
            if bitmap is not None and chunk.null_count:
                out[pos:pos + n][~_valid(bitmap, chunk.offset, n)] = np.nan
        pos += n
    return out


def float_array(values: np.ndarray, n: int) -> pa.Array:
    """float64 Arrow array of length ``n`` >= ``values.size``: ``values`` then nulls.

    NaN samples stay NaN (not nulls), as ``pyarrow.array(values, mask=...)`` gives them.
    """
    import pyarrow as pa

    values = np.asarray(values, dtype=np.float64)
    full = np.full(n, np.nan)
    full[:values.size] = values
    if values.size >= n:
        return pa.Array.from_buffers(pa.float64(), n, [None, pa.py_buffer(full)], null_count=0)
    valid = np.zeros(n, dtype=bool)
    valid[:values.size] = True
    bitmap = np.packbits(valid, bitorder="little")
    return pa.Array.from_buffers(pa.float64(), n, [pa.py_buffer(bitmap), pa.py_buffer(full)],
                                 null_count=n - values.size)


def arrow_owned(data: bytes) -> pa.Buffer:
    """A copy of ``data`` in memory Arrow owns (not a view of the Python object).

    pyarrow's threaded CSV reader finishes on its own worker threads and drops its last
    reference to the input there, sometimes after ``read_csv`` has returned. A buffer that
    wraps a Python object (``pa.BufferReader(bytes)``) then takes the GIL in its destructor on
    that worker: during interpreter shutdown Python ends such a thread (``pthread_exit``)
    and the C++ runtime aborts the process ("terminate called without an active exception",
    exit 134, after the command's output). An Arrow-owned buffer is freed without Python.
    """
    import pyarrow as pa

    buf = pa.allocate_buffer(len(data))
    np.frombuffer(buf, np.uint8)[:] = np.frombuffer(data, np.uint8)
    return buf
