"""Building the columns of a long table read back, with temporaries bounded by blocks
of rows: categoricals from integer codes (:func:`categorical_from_codes`, what
``astype("category")`` makes of the labels, without a label per row) and integer ticks
turned into float seconds in the column's own buffer (:func:`ticks_as_seconds`).

Used by :class:`~netcosim.columns.ColumnStore` when it builds a frame and by the tables'
transforms (the kernel's, the networks'); numpy and pandas are imported on first use.
"""

from __future__ import annotations

__all__ = ["categorical_from_codes", "ticks_as_seconds"]

#: rows mapped at a time by :func:`categorical_from_codes` (bounds its temporaries)
_BLOCK = 1 << 20


def categorical_from_codes(codes, labels, objects: bool = False):
    """``pandas.Series(labels[codes]).astype("category")``'s values built from the codes,
    without a label per row: categories sorted, only those used.  None unless every label
    used is a ``str``.  ``objects=True``: any hashable labels (e.g. task objects), as
    categories in the order of their codes, only those used.

    *codes*: an array of non-negative integers below ``len(labels)``; its temporaries are
    bounded (blocks of :data:`_BLOCK` rows), so a table of millions of rows needs little
    more than the result's one or two bytes a row."""
    import numpy as np
    import pandas as pd
    n = len(labels)
    seen = np.zeros(n, dtype=bool)
    for i in range(0, len(codes), _BLOCK):
        seen |= np.bincount(codes[i:i + _BLOCK], minlength=n) > 0
    used = np.flatnonzero(seen)
    used_labels = [labels[i] for i in used]
    # the distinct labels used (several codes may carry one label, e.g. a node's tasks)
    if objects:
        distinct = list(dict.fromkeys(used_labels))
        cats = pd.Index(distinct, dtype=object)
    else:
        if not all(type(x) is str for x in used_labels):
            return None
        distinct = sorted(set(used_labels))
        cats = pd.Index(pd.array(distinct, dtype="str"))
    position = {label: k for k, label in enumerate(distinct)}
    m = len(distinct)
    lut = np.full(n, -1, dtype=np.int8 if m < 0x80 else np.int16 if m < 0x8000 else np.int32)
    lut[used] = [position[label] for label in used_labels]
    mapped = np.empty(len(codes), dtype=lut.dtype)
    for i in range(0, len(codes), _BLOCK):
        np.take(lut, codes[i:i + _BLOCK], out=mapped[i:i + _BLOCK])
    return pd.Categorical.from_codes(mapped, dtype=pd.CategoricalDtype(cats))


def ticks_as_seconds(df, column: str, *, multiply: float | None = None, divide: float | None = None):
    """*df* with its integer-ticks *column* as float seconds: ``ticks * multiply`` or
    ``ticks / divide``, bit for bit what pandas' ``series * multiply`` or
    ``series.astype(float) / divide`` give, but converted in the column's own buffer (a
    table of millions of rows needs no second time array).  Returns a new DataFrame
    sharing every other column with *df*; *df* itself must not be used afterwards (its
    ticks are gone).  A column that is not 64-bit integers (e.g. objects with None) is
    converted by pandas, as before."""
    import numpy as np
    import pandas as pd
    col = df[column]
    if col.dtype != np.int64 or not len(col):
        ticks = pd.to_numeric(col, errors="coerce")
        seconds = ticks * multiply if multiply is not None else ticks.astype(float) / divide
    else:
        ticks = col.to_numpy()
        ticks.flags.writeable = True     # the frame's own buffer (read-only only as a view of it)
        seconds = ticks.view(np.float64)
        for i in range(0, len(ticks), _BLOCK):
            if multiply is not None:
                np.multiply(ticks[i:i + _BLOCK], multiply, out=seconds[i:i + _BLOCK])
            else:
                np.true_divide(ticks[i:i + _BLOCK], float(divide), out=seconds[i:i + _BLOCK])  # type: ignore[arg-type]
    cols = {c: (seconds if c == column else df[c]) for c in df.columns}
    return pd.DataFrame(cols, index=df.index, copy=False)
