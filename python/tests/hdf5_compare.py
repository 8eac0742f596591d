"""Every dataset and attribute of two result files, compared bit for bit."""

import h5py
import numpy as np

# The wall-clock seconds spent per stage: `/summary`'s `time_*` attributes. They are the one
# part of a result file that differs between two runs of the same scene.
TIMERS = "time_"


def differences(a_path, b_path, summary: bool = True) -> list[str]:
    """What differs between the result files at `a_path` and `b_path` (empty: equal), the
    `/summary` timers left out, and all of `/summary` unless `summary`."""
    found = []
    with h5py.File(a_path, "r") as a, h5py.File(b_path, "r") as b:
        names_a, names_b = _names(a), _names(b)
        if names_a != names_b:
            found.append(f"objects differ: {sorted(names_a ^ names_b)}")
        for name in sorted(names_a & names_b):
            obj_a, obj_b = a[name] if name != "/" else a, b[name] if name != "/" else b
            if isinstance(obj_a, h5py.Dataset) and not _same(obj_a[()], obj_b[()]):
                found.append(f"dataset {name}")
            skip = name == "/summary" and not summary
            attrs_a = {k for k in obj_a.attrs if not (skip or _timer(name, k))}
            attrs_b = {k for k in obj_b.attrs if not (skip or _timer(name, k))}
            if attrs_a != attrs_b:
                found.append(f"attributes of {name}: {sorted(attrs_a ^ attrs_b)}")
            for key in sorted(attrs_a & attrs_b):
                if not _same(obj_a.attrs[key], obj_b.attrs[key]):
                    found.append(f"attribute {name}@{key}")
    return found


def _timer(name: str, key: str) -> bool:
    return name == "/summary" and key.startswith(TIMERS)


def _names(f) -> set[str]:
    names = {"/"}
    f.visit(lambda n: names.add("/" + n))
    return names


def _same(x, y) -> bool:
    """Equal to the bit: NaN equals NaN, -0.0 differs from 0.0."""
    x, y = np.asarray(x), np.asarray(y)
    if x.dtype != y.dtype or x.shape != y.shape:
        return False
    if x.dtype.kind == "O":
        return x.tolist() == y.tolist()
    return x.tobytes() == y.tobytes()
