"""Reading the pickles the talking-head tools write, as data and nothing else.

FLAME's model files (``generic_model.pkl`` of FLAME 2020, ``flame2023.pkl``), its vertex masks
(``FLAME_masks.pkl``) and EMOTE's parameter files (``flame_*.pkl``, a dict of numpy arrays:
radekd91/inferno ``inferno_apps/TalkingHead/evaluation/evaluation_functions.py``) are Python
pickles. A pickle can run any code while it loads, so :func:`load_data_pickle` allows only what
those files are made of: dicts, lists, tuples, numbers, strings, numpy arrays and dtypes, and two
kinds of object it turns into arrays on the way:

* chumpy's ``Ch`` (FLAME 2020 keeps ``shapedirs`` and others as chumpy objects, which need the
  unmaintained chumpy package to unpickle): a terminal ``Ch`` keeps its value in the ``x`` of its
  state (mattloper/chumpy ``chumpy/ch.py``, ``__getstate__``/``__setstate__``), which is what is
  taken; a chumpy expression (anything else) is refused in one line;
* scipy's sparse matrices (FLAME 2020's ``J_regressor`` is a ``csc_matrix``): rebuilt as a
  dense array from the ``data``, ``indices``, ``indptr`` and shape of their state.

Anything else a pickle names (a module and a class) is refused with :class:`~app.errors.InputError`
naming the file and the class, before it is imported.

Example
-------
>>> import io, pickle
>>> import numpy as np
>>> blob = pickle.dumps({"lips": np.arange(3)}, protocol=2)
>>> load_data_pickle(io.BytesIO(blob), "masks.pkl")["lips"].tolist()
[0, 1, 2]
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import IO, Any

import numpy as np

from app.errors import InputError

#: Python 2 names of the builtins a protocol-2 pickle refers to.
_BUILTINS = {"__builtin__", "builtins", "copy_reg", "copyreg"}
_SAFE_BUILTINS = {
    "object": object,
    "dict": dict,
    "list": list,
    "tuple": tuple,
    "set": set,
    "frozenset": frozenset,
    "bytearray": bytearray,
    "complex": complex,
    "slice": slice,
}


def _reconstruct_array(cls: Any, shape: Any, dtype_code: Any) -> np.ndarray:
    """numpy's ``_reconstruct`` for an ndarray (the state is set after)."""
    if cls is not np.ndarray:
        raise pickle.UnpicklingError(f"an array of class {cls!r}")
    return np.ndarray.__new__(np.ndarray, shape, dtype_code)


def _reconstructor(cls: Any, base: Any, state: Any) -> Any:
    """``copyreg._reconstructor`` for the classes this reader allows."""
    if base is object and cls in (_ChumpyValue, _SparseMatrix):
        return cls.__new__(cls)
    if cls is np.ndarray and base is np.ndarray:
        return np.ndarray.__new__(np.ndarray, (0,), np.float64)
    raise pickle.UnpicklingError(f"an object of class {cls!r}")


def _encode(text: str, encoding: str = "utf-8") -> bytes:
    if not isinstance(text, str) or encoding not in ("latin1", "latin-1", "utf-8", "utf8"):
        raise pickle.UnpicklingError("an encoded string of another kind")
    return text.encode(encoding)


def _frombuffer(buf: bytes, dtype: np.dtype, shape: Any, order: str) -> np.ndarray:
    """numpy's ``_frombuffer`` (protocol 5 pickles of arrays): a copy, so it can be written."""
    flat = np.frombuffer(buf, dtype=dtype)
    return np.array(flat.reshape(shape, order="F" if order == "F" else "C"))


def _numpy_scalar(dtype: np.dtype, data: bytes | None = None) -> Any:
    return np.frombuffer(data or b"", dtype=dtype)[0] if data else dtype.type(0)


class _ChumpyValue:
    """Stands in for a chumpy ``Ch`` while unpickling; :func:`_plain` takes its ``x``."""

    state: dict[str, Any]

    def __setstate__(self, state: Any) -> None:
        self.state = state if isinstance(state, dict) else {}


class _SparseMatrix:
    """Stands in for a scipy sparse matrix while unpickling; :func:`_plain` makes it dense."""

    state: dict[str, Any]
    kind: str = "csc"

    def __setstate__(self, state: Any) -> None:
        self.state = state if isinstance(state, dict) else {}


def _sparse_kind(name: str) -> type[_SparseMatrix] | None:
    for kind in ("csc", "csr"):
        if name in (f"{kind}_matrix", f"{kind}_array"):
            return type(f"_Sparse_{kind}", (_SparseMatrix,), {"kind": kind})
    return None


class _DataUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        if module in _BUILTINS:
            if name == "_reconstructor":
                return _reconstructor
            if name in _SAFE_BUILTINS:
                return _SAFE_BUILTINS[name]
        if module == "_codecs" and name == "encode":  # bytes in a protocol-2 pickle of Python 3
            return _encode
        if module in ("numpy.core.multiarray", "numpy._core.multiarray"):
            if name == "_reconstruct":
                return _reconstruct_array
            if name == "scalar":
                return _numpy_scalar
        if module in ("numpy.core.numeric", "numpy._core.numeric") and name == "_frombuffer":
            return _frombuffer
        if module == "numpy" and name in ("ndarray", "dtype"):
            return np.ndarray if name == "ndarray" else np.dtype
        if module.startswith("chumpy") and name == "Ch":
            return _ChumpyValue
        if module.startswith("scipy.sparse"):
            kind = _sparse_kind(name)
            if kind is not None:
                return kind
        raise pickle.UnpicklingError(f"refused to load {module}.{name}")


def _dense(m: _SparseMatrix) -> np.ndarray:
    s = m.state
    shape = s.get("_shape") or s.get("shape")
    data, indices, indptr = (np.asarray(s.get(k)) for k in ("data", "indices", "indptr"))
    if shape is None or data.ndim != 1:
        raise ValueError("a sparse matrix without its data")
    rows, cols = (int(v) for v in shape)
    out = np.zeros((rows, cols), dtype=np.float64)
    major = cols if m.kind == "csc" else rows
    for j in range(major):
        lo, hi = int(indptr[j]), int(indptr[j + 1])
        if m.kind == "csc":
            out[indices[lo:hi], j] = data[lo:hi]
        else:
            out[j, indices[lo:hi]] = data[lo:hi]
    return out


def _plain(value: Any, path: str) -> Any:
    """The unpickled ``value`` with every stand-in turned into a numpy array."""
    if isinstance(value, _ChumpyValue):
        x = value.state.get("x")
        if not isinstance(x, np.ndarray):
            raise InputError(
                "holds a chumpy expression, not a stored value: load it with chumpy and save "
                "its arrays (numpy.savez) for facepair",
                path=path,
            )
        return x
    if isinstance(value, _SparseMatrix):
        try:
            return _dense(value)
        except (ValueError, IndexError, TypeError):
            raise InputError("holds a damaged sparse matrix", path=path) from None
    if isinstance(value, dict):
        return {k: _plain(v, path) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_plain(v, path) for v in value)
    return value


def load_data_pickle(source: str | Path | IO[bytes], name: str | None = None) -> Any:
    """The data a pickle holds (see the module's docstring for what is allowed), read with
    Python 2 strings as latin-1 as the FLAME files need; ``name`` names the file in errors."""
    label = name or str(source)
    try:
        if isinstance(source, (str, Path)):
            with open(source, "rb") as fh:
                value = _DataUnpickler(fh, encoding="latin1").load()
        else:
            value = _DataUnpickler(source, encoding="latin1").load()
    except FileNotFoundError:
        raise InputError("no such file", path=label) from None
    except pickle.UnpicklingError as exc:
        raise InputError(f"not a data pickle facepair reads: {exc}", path=label) from None
    except (EOFError, ValueError, TypeError, AttributeError, IndexError, KeyError) as exc:
        raise InputError(f"not a readable pickle ({type(exc).__name__})", path=label) from None
    return _plain(value, label)
