"""The six-parameter BRDF model family from Python: numpy arrays in and out.

The same core as the ``brdf`` command: :func:`eval` gives the values ``brdf eval`` prints,
:func:`fit` the report ``brdf fit --json`` prints (``FitResult.to_json()``), :func:`pack`
the blob ``brdf pack`` writes, :func:`select` the choice ``brdf select --json`` prints,
:func:`scene_lrcs`, :func:`scene_domain` and :func:`select_scene` what ``brdf scene
lrcs``, ``brdf scene domain`` and ``brdf select --scene`` compute, and errors are raised as :class:`ValueError` with the command's messages, located by array
index instead of CSV line.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import types
import warnings
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _brdf

__all__ = [
    "MODELS",
    "SWEEP_PIXELS",
    "IMAGE_PIXELS",
    "SUPERSAMPLE",
    "FitResult",
    "SceneLrcs",
    "SceneSelection",
    "Selection",
    "albedo",
    "eval",
    "eval_cosines",
    "eval_fit",
    "eval_vectors",
    "fit",
    "pack",
    "read",
    "scene_domain",
    "scene_image",
    "scene_lrcs",
    "scene_profile",
    "select",
    "select_scene",
    "to_json",
]

_log = logging.getLogger("brdf")

#: Model names accepted by every function (as ``brdf --model``).
MODELS: List[str] = list(_brdf.MODELS)
# Laser images' and sweeps' default resolutions (brdf_scene::image).
SWEEP_PIXELS: int = _brdf.SWEEP_PIXELS
IMAGE_PIXELS: int = _brdf.IMAGE_PIXELS
SUPERSAMPLE: int = _brdf.SUPERSAMPLE


def _params_text(params: Union[str, Mapping[str, float]]) -> str:
    """``kb=...,kr=...`` from a dict (values exactly as Python holds them) or a string."""
    if isinstance(params, str):
        return params
    if isinstance(params, Mapping):
        parts = []
        for name, value in params.items():
            # A number as Python holds it; True or "0.3" is refused, not read as 1 or 0.3.
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise ValueError(f"params: {name}: {value!r} is not a number")
            parts.append(f"{name}={float(value)!r}")
        return ",".join(parts)
    raise TypeError(f"params must be a dict or a 'name=value,...' string, not {type(params).__name__}")


def _real(name: str, a: Any) -> np.ndarray:
    """``a`` as a float64 array (no copy when it already is one); clear errors otherwise."""
    if isinstance(a, np.ma.MaskedArray):
        # np.asarray drops the mask: the masked elements would be evaluated or fitted.
        raise TypeError(f"{name}: a masked array's mask would be ignored; pass a.compressed() or a.filled(value)")
    arr = np.asarray(a)
    if arr.dtype == np.float64:
        return arr
    if arr.dtype.kind in "iuf":
        return arr.astype(np.float64)
    raise TypeError(f"{name}: dtype {arr.dtype} is not a real number type (need float or integer)")


def _precision(precision: str) -> np.dtype:
    if precision == "f64":
        return np.dtype(np.float64)
    if precision == "f32":
        return np.dtype(np.float32)
    raise ValueError(f"unknown precision `{precision}` (expected f64 or f32)")


def _located(names: Sequence[str], shape: tuple, err: Exception) -> ValueError:
    """An element error with its index in the caller's (broadcast) shape."""
    flat, message = err.args[0], err.args[1]
    index = np.unravel_index(flat, shape) if shape else ()
    where = "[" + ", ".join(str(int(i)) for i in index) + "]"
    return ValueError(f"{'/'.join(names)} at index {where}: {message}")


def _columns(names: Sequence[str], arrays: Sequence[Any]):
    """Broadcasts the inputs; returns the shape and flat contiguous float64 columns."""
    arrs = [_real(n, a) for n, a in zip(names, arrays)]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrs))
    except ValueError:
        shapes = ", ".join(f"{n} {a.shape}" for n, a in zip(names, arrs))
        raise ValueError(f"shapes do not broadcast: {shapes}") from None
    cols = [np.ascontiguousarray(np.broadcast_to(a, shape)).reshape(-1) for a in arrs]
    return shape, cols


def _shaped(out: np.ndarray, shape: tuple):
    out = out.reshape(shape)
    return out[()] if shape == () else out


def eval(model: str, params: Union[str, Mapping[str, float]], theta_i, theta_r, phi, *, precision: str = "f64", threads: Optional[int] = None):
    """The BRDF (1/sr) of ``model`` at zenith angles ``theta_i``, ``theta_r`` and relative
    azimuth ``phi`` in degrees (canonical convention: ``phi = 180`` is the mirror side),
    broadcast like numpy.

    ``params`` is a dict (``{"kb": 0.25, ...}``) or the CLI's ``"kb=0.25,kr=21.8,..."``.
    ``precision="f64"`` is the reference (the core's batch path, as ``brdf eval``);
    ``"f32"`` is the device's arithmetic (radians computed in f64, rounded once to f32).
    Returns float64 or float32 of the broadcast shape (a scalar for 0-d inputs).
    ``threads`` is how many threads do the work: ``None`` (the default) all cores, ``1``
    this thread alone, ``n`` a pool of ``n`` (at most 256; made once and kept); every value
    is the one a single thread gives, bit for bit. The GIL is released.
    Raises ValueError, with the index of the first bad element, for angles that are not
    finite, zeniths outside [0, 90] and values that are not finite.
    """
    _precision(precision)
    names = ("theta_i", "theta_r", "phi")
    shape, cols = _columns(names, (theta_i, theta_r, phi))
    try:
        out = _brdf.eval_angles(model, _params_text(params), *cols, precision, _threads(threads))
    except _brdf.ElementError as e:
        raise _located(names, shape, e) from None
    return _shaped(out, shape)


def eval_fit(
    fit,
    theta_i,
    theta_r,
    phi,
    *,
    index: Optional[int] = None,
    wavelength=None,
    precision: str = "f64",
    threads: Optional[int] = None,
):
    """The BRDF (1/sr) of a fit result at angles in degrees, as ``brdf eval --fit``:
    ``fit`` is a :class:`FitResult`, a list of them (what :func:`fit` returns for several
    datasets), or a path to what ``brdf fit --json`` or ``brdf select --chosen`` writes (or
    a hand-written ``{"model": ..., "params": {...}}``), a fitted table included (its base
    model times the tabulated correction, as ``brdf eval --fit``); ``index`` picks one fit of
    a batch.

    A spectral fit (the bands of one measurement, datasets ``FILE[wavelength=…]``) is
    evaluated at ``wavelength`` in µm, a number or an array broadcast with the angles: the
    band there, or the two bands around it blended linearly in wavelength; a wavelength
    outside the bands raises ValueError (no extrapolation). Otherwise as :func:`eval`.
    """
    if isinstance(fit, FitResult):
        if index is not None:
            raise TypeError("index picks a fit of a file or a list; a FitResult is one fit")
        text, origin = fit.to_json(), f"fit of {fit.dataset}"
    elif isinstance(fit, (list, tuple)) and fit and all(isinstance(r, FitResult) for r in fit):
        text, origin = to_json(list(fit)), "the fits"
    else:
        path = os.fspath(fit)
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise ValueError(f"cannot read {path}: {e.strerror}") from None
        except UnicodeDecodeError as e:
            raise ValueError(f"{path}: not UTF-8 text (byte {e.start})") from None
        origin = path
    index = _whole("index", index)
    _precision(precision)
    threads = _threads(threads)
    if wavelength is None:
        names = ("theta_i", "theta_r", "phi")
        shape, cols = _columns(names, (theta_i, theta_r, phi))
        parts = _brdf.fitted_at(text, origin, index)
        return _shaped(_eval_parts(parts, names, shape, cols, np.ones(cols[0].size, dtype=bool), precision, threads), shape)
    names = ("theta_i", "theta_r", "phi", "wavelength")
    shape, cols = _columns(names, (theta_i, theta_r, phi, wavelength))
    um = cols[3]
    bad = ~(np.isfinite(um) & (um > 0))
    if bad.any():
        first = int(bad.argmax())
        where = "[" + ", ".join(str(int(i)) for i in (np.unravel_index(first, shape) if shape else ())) + "]"
        raise ValueError(f"wavelength at index {where}: {um[first]!r} is not a wavelength above 0 (µm)")
    out = np.empty(um.size, dtype=_precision(precision))
    for w in np.unique(um):
        rows = um == w
        parts = _brdf.fitted_at(text, origin, index, float(w))
        out[rows] = _eval_parts(parts, names, shape, cols, rows, precision, threads)
    return _shaped(out, shape)


def _eval_parts(parts, names, shape, cols, rows, precision, threads):
    """The weighted sum of a fit's parts (one band, or two around a wavelength) at the
    selected ``rows`` of the flat columns; warns about directions outside a fitted table's
    coverage, as ``brdf eval --fit`` does."""
    picked = [np.ascontiguousarray(c[rows]) for c in cols[:3]]
    where_rows = np.flatnonzero(rows)
    total = None
    for weight, model, params, table in parts:
        try:
            if table is None:
                values = _brdf.eval_angles(model, params, *picked, precision, threads)
            else:
                values = _brdf.eval_angles(model, params, *picked, precision, threads, table)
        except _brdf.ElementError as e:
            flat, message = e.args[0], e.args[1]
            raise _located(names[:3], shape, _brdf.ElementError(int(where_rows[flat]), message)) from None
        if table is not None:
            covered = _brdf.table_covers(table, *picked)
            outside = int(covered.size - covered.sum())
            if outside:
                first = int(where_rows[int((~covered).argmax())])
                index = np.unravel_index(first, shape) if shape else ()
                where = "index [" + ", ".join(str(int(i)) for i in index) + "]"
                warnings.warn(
                    f"{outside} of {covered.size} directions (the first at {where}) lie outside the fitted "
                    "table's coverage: its measurements did not inform them, and the table extrapolates there",
                    stacklevel=3,
                )
        # One band: its values as they are (bit for bit `eval`); two: the weighted sum.
        if len(parts) == 1:
            return values
        term = values.dtype.type(weight) * values
        total = term if total is None else total + term
    return total


def eval_cosines(model: str, params: Union[str, Mapping[str, float]], cos_theta_i, cos_theta_r, cos_phi, *, precision: str = "f64", threads: Optional[int] = None):
    """The BRDF at cosines of the zenith angles and of the relative azimuth, broadcast like
    numpy; see :func:`eval`. Zenith cosines lie in [0, 1] (0 is the horizon) and ``cos_phi``
    in [-1, 1]: a negative zenith cosine (a zenith beyond 90 degrees, below the horizon,
    which :func:`eval` refuses too), a value outside [-1, 1] or one that is not finite raises
    ValueError with the index of the first bad element."""
    dtype = _precision(precision)
    names = ("cos_theta_i", "cos_theta_r", "cos_phi")
    shape, cols = _columns(names, (cos_theta_i, cos_theta_r, cos_phi))
    try:
        out = _brdf.eval_columns(model, _params_text(params), cols, precision, _threads(threads))
    except _brdf.ElementError as e:
        raise _located(names, shape, e) from None
    return _shaped(out.astype(dtype, copy=False), shape)


def eval_vectors(model: str, params: Union[str, Mapping[str, float]], wi, wr, *, precision: str = "f64", threads: Optional[int] = None):
    """The BRDF at unit direction vectors ``wi`` (towards the source) and ``wr`` (towards
    the viewer), arrays of shape ``(..., 3)`` in the surface frame (z the normal),
    broadcast like numpy over the leading axes; see :func:`eval`."""
    dtype = _precision(precision)
    wi = _real("wi", wi)
    wr = _real("wr", wr)
    for n, a in (("wi", wi), ("wr", wr)):
        if a.ndim == 0 or a.shape[-1] != 3:
            raise ValueError(f"{n}: shape {a.shape}: the last axis must hold x, y, z (length 3)")
    names = ("wi", "wr")
    parts = [wi[..., k] for k in range(3)] + [wr[..., k] for k in range(3)]
    shape, cols = _columns(["wi"] * 3 + ["wr"] * 3, parts)
    try:
        out = _brdf.eval_columns(model, _params_text(params), cols, precision, _threads(threads))
    except _brdf.ElementError as e:
        raise _located(names, shape, e) from None
    return _shaped(out.astype(dtype, copy=False), shape)


def albedo(model: str, params: Union[str, Mapping[str, float]], theta_i, *, panels: Optional[int] = None):
    """Directional-hemispherical reflectance (dimensionless) at incidence ``theta_i``
    (degrees, any shape), by the composite Gauss-Legendre rule of
    ``brdf_core::checks::AlbedoRule`` with ``panels`` panels (``AlbedoRule::MIN_PANELS`` to
    ``MAX_PANELS``, 2 to 1024: the cost grows as panels squared; ``ValueError`` outside), or by default the rule of the
    fit report's energy check (8 panels, more for a narrow microfacet peak:
    ``AlbedoRule::for_model``), so that ``albedo(model, r.params, t)`` equals
    ``r.energy["albedo"]`` at the report's incidences. Above 1 means the model does not
    conserve energy there.
    """
    shape, (col,) = _columns(("theta_i",), (theta_i,))
    try:
        out = _brdf.albedo(model, _params_text(params), col, None if panels is None else _whole("panels", panels))
    except _brdf.ElementError as e:
        raise _located(("theta_i",), shape, e) from None
    return _shaped(out, shape)


class FitResult:
    """One fit, as ``brdf fit --json`` reports it.

    Attributes: ``dataset``, ``wavelength`` (µm, for a band of a spectral measurement; else
    None), ``model``, ``params`` (name -> value, the paper's order),
    ``std_errors`` (name -> standard error or None), ``correlation`` (the report's
    correlation matrix), ``undetermined`` (name -> reason, for parameters the data do not
    determine), ``metrics``, ``energy``, ``converged`` and ``report`` (the whole report as
    a dict). ``to_json()`` is the text ``brdf fit --json`` prints for the same input.

    ``FitResult(text)`` also takes the hand-written form ``brdf pack`` reads,
    ``{"model": ..., "params": {...}}``: a field the text leaves out is None (``std_errors``
    and ``undetermined`` empty). Text that is not one fit result, or a field of the wrong type
    (``"converged": "no"``), raises ``ValueError`` naming the field.

    A result is read-only: :meth:`eval`, :func:`pack` and :func:`to_json` use the report as
    the fit wrote it, so an edited parameter would be silently ignored by them. Assigning an
    attribute or changing a mapping raises ``TypeError`` or ``AttributeError``; to evaluate
    other parameters, pass them to :func:`eval` (``dict(result.params)`` is an editable copy).
    """

    def __init__(self, text: str):
        r = _fit_result_fields(text)
        unc = r.get("uncertainty") or {}
        per_param = _pairs(unc.get("params") or {})
        fields = {
            "_text": text,
            "report": _frozen(r),
            "dataset": r.get("dataset"),
            "wavelength": None if r.get("dataset") is None else _brdf.band_of(r["dataset"]),
            "model": r["model"],
            "params": _frozen(dict(_pairs(r["params"]))),
            "std_errors": _frozen({name: u.get("se") for name, u in per_param}),
            "undetermined": _frozen(
                {name: (u.get("note") or "") for name, u in per_param if not u.get("determined", True)}
            ),
            "correlation": _frozen(unc.get("correlation")),
            "metrics": _frozen(r.get("metrics")),
            "energy": _frozen(r.get("energy")),
            "converged": r.get("converged"),
        }
        for k, v in fields.items():
            object.__setattr__(self, k, v)

    def __setattr__(self, name, value):
        raise AttributeError(
            f"a FitResult is read-only (`{name}`): eval, pack and to_json use the report as fitted; "
            "pass edited parameters to brdf.eval instead"
        )

    def __delattr__(self, name):
        self.__setattr__(name, None)

    def to_json(self) -> str:
        """The report exactly as ``brdf fit --json`` prints one (without its final newline)."""
        return self._text

    def eval(self, theta_i, theta_r, phi, *, precision: str = "f64", threads: Optional[int] = None):
        """This fit's BRDF at angles in degrees: :func:`eval_fit` of it."""
        return eval_fit(self, theta_i, theta_r, phi, precision=precision, threads=threads)

    def __repr__(self) -> str:
        ps = ", ".join(f"{k}={v:.6g}" for k, v in self.params.items())
        if self.metrics is None:
            # A hand-written result: model and parameters alone.
            return f"FitResult({self.dataset!r}, {self.model}: {ps})"
        rms = self.metrics.get("rms_rel")
        # Absolute residuals with a zero reading leave the relative error undefined (null).
        rms = "undefined" if rms is None else f"{rms:.3g}"
        table = self.report.get("fitted_table")
        if table is not None:
            # The metrics are the base model's; the table's own error is in the selection.
            nodes = "x".join(str(n) for n in table["nodes"])
            return f"FitResult({self.dataset!r}, {self.model} + fitted table {nodes}: {ps}; base rms_rel {rms})"
        return f"FitResult({self.dataset!r}, {self.model}: {ps}; rms_rel {rms})"


# The fields of a fit result that FitResult reads beyond the model and parameters (which the
# library checks), with the JSON type each must have when present and not null.
_FIT_RESULT_TYPES = {
    "dataset": (str, "a string"),
    "converged": (bool, "true or false"),
    "metrics": (dict, "an object"),
    "energy": (dict, "an object"),
    "uncertainty": (dict, "an object"),
}


def _json_kind(v) -> str:
    """The JSON name of a parsed value's type, for messages."""
    for t, name in ((bool, "a boolean"), (dict, "an object"), (list, "an array"), (str, "a string")):
        if isinstance(v, t):
            return name
    return "null" if v is None else "a number"


def _fit_result_fields(text):
    """The parsed object of one fit result, or ValueError naming what is wrong: not JSON, not
    one object, refused by the library's reader (model, parameters, unknown fields), or a
    field FitResult reads of the wrong type."""
    if not isinstance(text, str):
        raise TypeError(f"FitResult takes the JSON text of one fit, not {type(text).__name__}")
    try:
        r = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"FitResult: not JSON: {e}") from None
    if not isinstance(r, dict):
        raise ValueError(
            f"FitResult: one fit result is a JSON object, not {_json_kind(r)} "
            "(for the fits of an array, FitResult(json.dumps(item)) for each item)"
        )
    for name, (t, what) in _FIT_RESULT_TYPES.items():
        v = r.get(name)
        if v is not None and not isinstance(v, t):
            raise ValueError(f"FitResult: field `{name}` must be {what}, not {_json_kind(v)} ({v!r})")
    params = r.get("params")
    if isinstance(params, dict):
        for name, v in params.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f"FitResult: field `params.{name}` must be a number, not {_json_kind(v)} ({v!r})")
    # The model, each of its parameters once, no unknown field: the library's reader.
    _brdf.check_fit(text)
    unc = r.get("uncertainty") or {}
    if unc.get("params") is not None:
        if not isinstance(unc["params"], (dict, list)):
            raise ValueError("FitResult: field `uncertainty.params` must be an object")
        for pair in _pairs(unc["params"]) if isinstance(unc["params"], dict) else unc["params"]:
            if not (isinstance(pair, (list, tuple)) and len(pair) == 2 and isinstance(pair[1], dict)):
                raise ValueError(f"FitResult: field `uncertainty.params` holds {pair!r}, not a name and an object")
    return r


def _frozen(v):
    """A read-only view of a parsed JSON value: objects as mapping proxies, arrays as tuples."""
    if isinstance(v, dict):
        return types.MappingProxyType({k: _frozen(x) for k, x in v.items()})
    if isinstance(v, list):
        return tuple(_frozen(x) for x in v)
    return v


def _pairs(v):
    """Name/value pairs from the report's ordered maps (a list of pairs or an object)."""
    if isinstance(v, dict):
        return list(v.items())
    return [tuple(p) for p in v]


def _settings(model, seed, residual, engine, options) -> "_brdf.Settings":
    known = {
        "chains", "agree", "hops", "anneal_evals", "loss", "loss_scale", "brightening",
        "budget_evals", "skip_invalid", "format", "channel", "band", "noise_floor", "bands",
    }
    unknown = set(options) - known
    if unknown:
        raise TypeError(f"unknown option(s): {', '.join(sorted(unknown))} (known: {', '.join(sorted(known))})")
    o = dict(options)
    whole = {k: _whole(k, o.get(k)) for k in ("chains", "agree", "hops", "anneal_evals", "budget_evals")}
    return _brdf.Settings(
        _text("model", model), _whole("seed", seed), _text("residual", residual), _text("engine", engine),
        whole["chains"], whole["agree"], whole["hops"], whole["anneal_evals"],
        _text("loss", o.get("loss", "linear")),
        None if o.get("loss_scale") is None else _number("loss_scale", o["loss_scale"]),
        _flag("brightening", o.get("brightening", False)),
        whole["budget_evals"], _flag("skip_invalid", o.get("skip_invalid", False)),
        None if o.get("format") is None else _text("format", o["format"]), None if o.get("channel") is None else _text("channel", o["channel"]),
        None if o.get("band") is None else _number("band", o["band"]),
        None if o.get("noise_floor") is None else _number("noise_floor", o["noise_floor"]),
        None if o.get("bands") is None else _text("bands", o["bands"]),
    )


# Options are taken as given or refused: a float where a count belongs, a string where a flag
# belongs, are errors, never truncated or read as true.
def _whole(name: str, v):
    """A whole number >= 0 (or None), as the CLI's integer options; bools are refused."""
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise TypeError(f"{name} must be a whole number, not {v!r}")
    if v < 0:
        raise ValueError(f"{name}: `{v}` is not a whole number >= 0")
    if v > 0xFFFFFFFFFFFFFFFF:
        raise ValueError(f"{name}: `{v}` is larger than any 64-bit whole number")
    return int(v)


def _flag(name: str, v) -> bool:
    if not isinstance(v, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, not {v!r}")
    return bool(v)


def _threads(v) -> int:
    """``threads=`` as the extension takes it: 0 for all cores, else the count."""
    if v is None:
        return 0
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise TypeError(f"threads must be None or a whole number, not {v!r}")
    if not 1 <= int(v) <= 256:
        raise ValueError(f"threads {v}: give 1 to 256, or None for all cores")
    return int(v)


def _number(name: str, v) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, not {v!r}")
    return float(v)


def _text(name: str, v) -> str:
    if not isinstance(v, str):
        raise TypeError(f"{name} must be a string, not {v!r}")
    return v


def _split_advice(column: str, each: str, alone: str) -> str:
    """What to do with a field that would split a file into datasets (a CSV file's ``sample``
    or ``wavelength`` column, which ``brdf fit`` splits by): arrays are one dataset."""
    return (
        f"arrays are one dataset; fit each {each} on its own ({alone}), or pass the path of a CSV "
        f"file with a `{column}` column (brdf.fit fits each {each} of it, as `brdf fit` does)"
    )



def _data_fields(data):
    """The fields of an array dataset, as ``(names, get)``. ``get(name)`` reads one field, or
    gives None when the dataset has none of that name: a mapping's key, a structured or record
    array's field, a data frame's column (pandas or polars: a ``columns`` attribute of its
    class, columns by name), or another object's attribute (``getattr``: a property, a slot,
    a dataclass's or named tuple's field). ``names`` lists the fields, only to find near
    misses of the known ones (``Sigma``, ``sigmas``, ``sample_id``) and a ``sample``: a
    mapping's keys, ``dtype.names``, the columns, a named tuple's or dataclass's fields, or
    another object's public attributes other than methods (``dir()``)."""
    if isinstance(data, Mapping):
        return list(data), lambda k: data.get(k)
    if isinstance(data, np.ndarray) and data.dtype.names is not None:
        fields = list(data.dtype.names)
        return fields, lambda k: data[k] if k in fields else None
    if isinstance(data, np.ndarray):
        raise TypeError(
            f"data: an array of dtype {data.dtype} has no named columns; pass a dict of arrays "
            "theta_i, theta_r, phi, brdf (or a structured array with those fields)"
        )
    if hasattr(type(data), "columns") and hasattr(data, "__getitem__"):
        columns = list(data.columns)
        return columns, lambda k: data[k] if k in columns else None
    get = lambda k: getattr(data, k, None)  # noqa: E731
    if isinstance(data, tuple) and isinstance(getattr(data, "_fields", None), tuple):
        return list(data._fields), get
    if dataclasses.is_dataclass(data) and not isinstance(data, type):
        return [f.name for f in dataclasses.fields(data)], get
    names = [k for k in dir(data) if not k.startswith("_") and not callable(getattr(type(data), k, None))]
    return names, get


def _data_name(data, given):
    """The name of an array dataset: ``name=`` if given, else the dataset's ``name`` (a
    string: a dict's key, as :func:`read` returns it, or a field), else ``arrays``; with the
    dataset's ``wavelength`` (µm, one number; None for none) as its band,
    ``NAME[wavelength=…]``, as a spectral file's datasets are named (so that the fit carries
    it)."""
    _, get = _data_fields(data)
    field = get("name")
    if field is not None and not isinstance(field, str):
        raise TypeError(f"data: `name` must be a string (the dataset's name), not {type(field).__name__}")
    name = given if given is not None else (field if field is not None else "arrays")
    um = get("wavelength")
    if um is None:
        return name
    if np.ndim(um) != 0:
        raise ValueError(
            "data: `wavelength` holds a value per point, and a dataset is of one band: "
            + _split_advice("wavelength", "band", "its rows, with `wavelength` one number in µm")
        )
    return _brdf.named_band(name, _number("data: wavelength", um))


def _array_columns(data):
    """The columns of an array dataset (a dict or another object with fields: see
    :func:`_data_fields`), flattened.

    One value per measurement: every column has the same shape (none is broadcast, so a
    column of shape (N, 1) beside ones of shape (N,) is an error, not N^2 points). Fields are
    checked by the CSV reader's column rule (``brdf_fit::data::check_column_names``, through
    the binding: one rule): a near miss of a known one is refused (``Sigma``, ``sigmas``,
    ``sample_id``, ``wavelength_nm``: it would be ignored), any other field ignored
    (``index``, ``operator``, ``units``). A ``sample`` field would merge the samples into one
    fit, and ``theta_s`` is read from files only: both are refused."""
    names, get = _data_fields(data)
    miss = _brdf.column_near_miss([str(k) for k in names])
    if miss is not None:
        raise ValueError(f"data: {miss}")
    if "sample" in names:
        raise ValueError(
            "data: `sample`: the samples would be merged into one fit: "
            + _split_advice("sample", "sample", "its rows, without the `sample` field")
        )
    if "theta_s" in names:
        raise ValueError(
            "data: `theta_s`: arrays take theta_r and phi (degrees); the signed in-plane form "
            "theta_i, theta_s, brdf is read from files only (pass the path of a CSV file)"
        )
    cols = {}
    for k in ("theta_i", "theta_r", "phi", "brdf"):
        v = get(k)
        if v is None:
            raise ValueError(f"data: missing `{k}` (need theta_i, theta_r, phi, brdf; optional sigma or weight)")
        cols[k] = _real(k, v)
    for k in ("sigma", "weight"):
        v = get(k)
        if v is not None:
            cols[k] = _real(k, v)
    names = list(cols)
    shapes = {a.shape for a in cols.values()}
    if len(shapes) > 1:
        raise ValueError(
            "data: the columns differ in shape ("
            + ", ".join(f"{n} {a.shape}" for n, a in cols.items())
            + "); give one value per measurement in each"
        )
    shape, flat = _columns(names, list(cols.values()))
    return shape, dict(zip(names, flat))


def _no_name_for_files(name) -> None:
    """Refuses ``name=`` with files, where it would be ignored."""
    if name is not None:
        raise ValueError("name names an array dataset; a file's datasets are named by the file")


def _is_paths(data) -> bool:
    if isinstance(data, (bytes, bytearray)) or (
        isinstance(data, (list, tuple)) and any(isinstance(p, (bytes, bytearray)) for p in data)
    ):
        raise TypeError("paths must be str or os.PathLike, not bytes (decode them first)")
    return isinstance(data, (str, os.PathLike)) or (
        isinstance(data, (list, tuple)) and bool(data) and all(isinstance(p, (str, os.PathLike)) for p in data)
    )


def fit(data, model: str = "six", *, seed: int = 1, residual: str = "relative", engine: str = "full", **options):
    """Fits ``model`` to measured data, as ``brdf fit``.

    ``data`` is a path (or a list of paths) to any file ``brdf fit`` reads (``format=`` as
    ``--format``: ``cornell``, ``nist``, ``merl-inplane``), or one dataset of arrays: a dict,
    a structured or record array, a data frame (pandas, polars) or an object with attributes
    (``types.SimpleNamespace``, a dataclass, a named tuple), holding ``theta_i``,
    ``theta_r``, ``phi`` (degrees), ``brdf`` (1/sr) and optionally ``sigma`` or ``weight``,
    ``name`` (a string) and ``wavelength`` (one number, µm: the fit is of that band). Other
    keys, fields and columns are treated as a CSV file's columns are (one rule, the
    library's): a near miss of a known one is refused with what to do (ValueError: ``Sigma``,
    ``sigmas``, ``sample_id``, ``wavelength_nm``; a misspelt ``sigmas`` would drop the
    uncertainties) and any other is ignored (``index``, ``operator``, a data frame's
    ``Unnamed: 0``). Fields are read by name (properties too). A ``sample`` column, or a
    wavelength per point, is refused with advice rather than
    split: arrays are one dataset, so fit each sample (or band) on its own, or pass the path of
    a CSV file, whose datasets are split by ``sample`` and ``wavelength`` as ``brdf fit``
    splits them. Zeniths that all look like radians are warned of as for a file; the
    file options (``format``, ``channel``, ``band``, ``skip_invalid``) and
    ``bands='shared'`` are refused for arrays, where they would be ignored. Options as the
    CLI's flags: ``chains``, ``agree``, ``hops``,
    ``anneal_evals``, ``loss``, ``loss_scale``, ``brightening``, ``budget_evals``,
    ``noise_floor`` (1/sr; estimated where readings are at or below zero when not given, 0
    for none), ``skip_invalid``, ``channel``, ``band`` (a wavelength in µm of a spectral
    file), ``bands`` (``independent``, the default, or ``shared``: one shape for all bands
    of a spectral file, weights per band; refused where no two datasets are bands of one
    measurement, as ``brdf fit`` refuses it); ``name`` names an array dataset (a file's
    datasets are named by the file: refused with a path).

    Returns a :class:`FitResult` for one dataset, a list of them for several (a file with
    ``sample``/``wavelength`` columns, or several files). What ``brdf fit`` warns of on
    standard error comes as warnings: a doubtful estimated noise floor, and with
    ``engine='embedded'`` a weight that ended on the engine's search bound.
    """
    name = options.pop("name", None)
    s = _settings(model, seed, residual, engine, options)
    if _is_paths(data):
        _no_name_for_files(name)
        paths = [os.fspath(data)] if isinstance(data, (str, os.PathLike)) else [os.fspath(p) for p in data]
        texts, notes = _brdf.fit_paths(s, paths)
        for note in notes:
            # What `brdf fit` lists on standard error (rows skipped or rejected).
            warnings.warn(note, stacklevel=2)
        results = [_noted(FitResult(t)) for t in texts]
        return results[0] if len(results) == 1 else results
    name = _data_name(data, name)
    shape, flat = _array_columns(data)
    try:
        text, notes = _brdf.fit_arrays(
            s, name, flat["theta_i"], flat["theta_r"], flat["phi"], flat["brdf"],
            flat.get("sigma"), flat.get("weight"),
        )
    except _brdf.ElementError as e:
        raise _located(["data"], shape, e) from None
    for note in notes:
        # What a file's reader warns of the same rows (zeniths that look like radians).
        warnings.warn(note, stacklevel=2)
    return _noted(FitResult(text))


def _noted(r: "FitResult") -> "FitResult":
    """``r``, after warning of what ``brdf fit`` warns of on standard error (a doubtful
    estimated noise floor; a weight the embedded engine left on its search bound)."""
    floor = r.report.get("noise_floor")
    if floor is not None and floor.get("note"):
        warnings.warn(f"{r.dataset}: {floor['note']}", stacklevel=3)
    for note in (r.report.get("search") or {}).get("on_search_box") or ():
        warnings.warn(f"{r.dataset}: {note}", stacklevel=3)
    return r


class Selection:
    """What ``brdf select DATA --json`` reports: every model of the ladder fitted over the
    angular domain, every device representation of each (exact in f32, six-parameter tables
    of 64, 256 and 1024 nodes, and from 50 points the fitted table ``ggx + table``) with
    its error against the data, its Cortex-M4F instructions
    per lookup, this host's ns (measured in the call) and its blob size, its held-out error
    (``cv_rms_rel``: 5-fold cross-validation) beside its training error (``rms_rel``), and the
    one chosen by the held-out error.

    Attributes: ``chosen`` (the representation's name: the cheapest within the budget, or the
    most accurate when none is; None only when nothing could be cross-validated),
    ``within_budget`` (whether it meets the budget), ``reason`` (why),
    ``chosen_fit`` (the :class:`FitResult` it comes from, with its fitted table when that was
    chosen, as ``brdf select --chosen`` writes it; or None), ``candidates`` (a
    :class:`FitResult` per model of the ladder),
    ``representations`` (a dict per representation), ``blob`` (the chosen representation as
    the parameter blob ``brdf select -o`` writes, or None), ``report`` (the whole JSON as a
    dict). ``to_json()`` is the text ``brdf select --json`` prints for the same input and
    seed (its ``host_ns`` and ``seconds`` fields are timings of this run).
    """

    def __init__(self, text: str, candidates: Sequence[str], blob: Optional[bytes], chosen: Optional[str]):
        self._text = text
        self.report: Dict[str, Any] = json.loads(text)
        r = self.report
        self.dataset: str = r["dataset"]
        self.budget: float = r["budget"]
        self.n: int = r["n"]
        self.chosen: Optional[str] = r["chosen"]
        self.within_budget: bool = r["within_budget"]
        self.reason: str = r["reason"]
        self.candidates: List[FitResult] = [FitResult(c) for c in candidates]
        # As `brdf select --chosen` writes it: with its fitted table when that was chosen.
        self.chosen_fit: Optional[FitResult] = None if chosen is None else FitResult(chosen)
        self.representations: List[Dict[str, Any]] = r["representations"]
        self.blob: Optional[bytes] = blob

    def to_json(self) -> str:
        """The selection exactly as ``brdf select --json`` prints it (without its final newline)."""
        return self._text

    def __repr__(self) -> str:
        return f"Selection({self.dataset!r}, {self.n} points, chosen: {self.chosen}: {self.reason})"


def select(
    data,
    *,
    budget: float = 0.02,
    max_theta: float = 90.0,
    max_theta_i: Optional[float] = None,
    max_theta_r: Optional[float] = None,
    allow_nonphysical: bool = False,
    sequence: int = 1,
    seed: int = 1,
    residual: str = "relative",
    **options,
) -> Selection:
    """The simplest model, and the cheapest device representation, that meet an error budget
    over the angular domain a scene uses, as ``brdf select DATA``.

    ``data`` is one dataset: a path to any file ``brdf fit`` reads (``format=`` and
    ``channel=`` as for :func:`fit`) or arrays ``theta_i``, ``theta_r``, ``phi`` (degrees),
    ``brdf`` (1/sr) and optionally ``sigma`` or ``weight``, held and checked as for
    :func:`fit` (a dict, a structured array, a data frame or an object with attributes; a
    near miss of a known field refused, other fields ignored, a ``sample`` column refused with
    advice: select each sample on its own).
    ``bands='shared'`` is refused (one dataset is no bands of a measurement; it would be
    ignored). ``budget`` is
    the largest acceptable RMS relative error (a fraction: 0.02 is 2%; at most 1); the domain keeps the
    points with ``theta_i <= max_theta_i`` and ``theta_r <= max_theta_r`` (both default to
    ``max_theta``, degrees); ``allow_nonphysical`` lets the choice fall on a model that is not
    reciprocal or is unbounded at grazing; ``sequence`` is the sequence number of the
    returned blob. The fit options are :func:`fit`'s (``chains``, ``loss``, ...; the full
    engine). Points left out of the domain, rows skipped and zeniths that look like radians
    are reported as warnings.
    """
    name = options.pop("name", None)
    s = _settings("six", seed, residual, "full", options)
    mi = _number("max_theta_i", max_theta if max_theta_i is None else max_theta_i)
    mr = _number("max_theta_r", max_theta if max_theta_r is None else max_theta_r)
    sequence = _whole("sequence", sequence)
    if not 0 <= sequence <= 0xFFFFFFFF:
        raise ValueError(f"sequence {sequence}: outside 0..=4294967295")
    args = (_number("budget", budget), mi, mr, _flag("allow_nonphysical", allow_nonphysical), sequence)
    if isinstance(data, (str, os.PathLike)):
        _no_name_for_files(name)
        done, notes, error = _brdf.select_path(s, os.fspath(data), args)
    elif _is_paths(data):
        raise TypeError("select works on one dataset: give one path")
    else:
        name = _data_name(data, name)
        shape, flat = _array_columns(data)
        try:
            done, notes, error = _brdf.select_arrays(
                s, name, flat["theta_i"], flat["theta_r"], flat["phi"], flat["brdf"],
                flat.get("sigma"), flat.get("weight"), args,
            )
        except _brdf.ElementError as e:
            raise _located(["data"], shape, e) from None
    for note in notes:
        warnings.warn(note, stacklevel=2)
    if error is not None:
        raise ValueError(error)
    text, candidates, blob, chosen = done
    return Selection(text, candidates, blob, chosen)


def read(
    path,
    format: Optional[str] = None,
    channel: Optional[str] = None,
    *,
    band: Optional[float] = None,
    skip_invalid: bool = False,
):
    """The datasets of a file as ``brdf fit`` reads it (``format`` as ``--format``:
    ``cornell``, ``nist``, ``merl-inplane``; ``channel`` r, g or b for Cornell RGB files;
    ``band`` one wavelength in µm of a spectral Cornell or NIST file, every band otherwise,
    each its own dataset named ``FILE[wavelength=…]``). Readings at or below zero are kept.

    Returns a list of dicts, one per dataset: ``name``, ``wavelength`` (µm, the band of a
    spectral or multi-wavelength file; None otherwise) and float64 arrays ``theta_i``,
    ``theta_r``, ``phi`` (degrees, canonical convention) and ``brdf`` (1/sr), plus ``sigma``
    or ``weight`` where the file gives them. Rows the CLI would skip or reject are reported
    as warnings.
    """
    opts = {"format": format, "channel": channel, "band": band, "skip_invalid": skip_invalid}
    s = _settings("six", 1, "relative", "full", opts)
    sets, notes = _brdf.read_paths(s, [os.fspath(path)])
    for note in notes:
        warnings.warn(note, stacklevel=2)
    out = []
    for name, ti, tr, phi, f, sigma, weight in sets:
        d = {
            "name": name,
            "wavelength": _brdf.band_of(name),
            "theta_i": np.array(ti),
            "theta_r": np.array(tr),
            "phi": np.array(phi),
            "brdf": np.array(f),
        }
        for key, col in (("sigma", sigma), ("weight", weight)):
            if col and all(v is not None for v in col):
                d[key] = np.array(col, dtype=np.float64)
        out.append(d)
    return out


def to_json(results) -> str:
    """The text ``brdf fit --json`` prints for one result or a list of them (an array for
    several), without the final newline."""
    if isinstance(results, FitResult):
        return results.to_json()
    texts = [r.to_json() for r in results]
    if len(texts) == 1:
        return texts[0]
    return "[\n" + ",\n".join(texts) + "\n]"


def pack(results, table_nodes: Optional[int] = None, *, sequence: int = 1) -> bytes:
    """The parameter blob ``brdf pack`` writes, as bytes (flash it with ``brdf flash``).

    ``results`` is a :class:`FitResult`, a path to a ``brdf fit --json`` file (one report or
    an array; hand-written ``{"model": ..., "params": {...}}`` too), or a list of either:
    one material per fit, in order, except that the bands of one spectral measurement (fits
    of ``FILE[wavelength=...]``, in any of them) become one banded material the device
    answers at a wavelength (an INFO record names each material's fits). ``table_nodes`` adds lookup tables of that many nodes to
    every six-parameter material (the device's fast path; 256 nodes = 3,072 bytes per
    material); ``sequence`` is the blob's sequence number (a device keeps the newer blob).

    Messages name each fit by its file (``fits.json: fit 0``) or, for results, by
    ``results`` (one) or ``results[k]`` (in a list). What ``brdf pack`` prints on standard
    error comes as :mod:`warnings` (no proof of energy conservation, tables above or
    without a promise) or as INFO records of the ``brdf`` logger (each table's measured
    error). Raises ValueError with the CLI's message for parameters outside their ranges,
    unreadable files, more than 8 materials or a blob larger than a slot; TypeError for
    anything that is not a result or a path.
    """

    def source(item, origin):
        if isinstance(item, FitResult):
            return (origin, item.to_json())
        if isinstance(item, (str, os.PathLike)):
            return (os.fspath(item), None)
        raise TypeError(
            f"{origin}: {type(item).__name__} is not a FitResult or a path to a `brdf fit --json` file"
        )

    if isinstance(results, (list, tuple)):
        if not results:
            raise ValueError("results: no fits to pack")
        sources = [source(r, f"results[{k}]") for k, r in enumerate(results)]
    else:
        sources = [source(results, "results")]
    if table_nodes is not None:
        table_nodes = _whole("table_nodes", table_nodes)
        if table_nodes < 0:
            raise ValueError(f"{table_nodes} table nodes: not a count")
    sequence = _whole("sequence", sequence)
    if not 0 <= sequence <= 0xFFFFFFFF:
        raise ValueError(f"sequence {sequence}: outside 0..=4294967295")
    blob, notes, error = _brdf.pack(sources, table_nodes, sequence)
    for is_warning, text in notes:
        if is_warning:
            warnings.warn(text, stacklevel=2)
        else:
            _log.info(text)
    if error is not None:
        raise ValueError(error)
    return blob


class SceneLrcs:
    """A target's laser radar cross-section over its sensor sweep, as ``brdf scene lrcs``
    computes it: per aspect ``azimuth`` and ``elevation`` (degrees), ``lrcs`` (sigma, m^2),
    ``by_material`` (each material's share, m^2: shape (aspects, materials), columns in
    scene order, named by ``parts``) and ``facets_seen`` (facets seen by both source and
    receiver), all numpy arrays in sweep order; ``seconds`` (the sweep's wall time) and
    ``report`` (the whole JSON as a dict). ``to_json()`` is the text ``brdf scene lrcs
    --json`` prints for the same scene (its ``seconds`` is this run's). For a scene that lists
    wavelengths (``[sensor] wavelength_um = [0.45, 0.55]``), ``wavelengths`` (µm) and
    ``by_wavelength`` (sigma at each: shape (aspects, wavelengths); ``lrcs`` is its first
    column); both None otherwise. ``sampling_bound`` (m^2 per aspect) with
    ``visibility="area"``, None otherwise.
    """

    def __init__(self, text, azimuth, elevation, lrcs, by_material, facets_seen, parts):
        self._text = text
        self.report: Dict[str, Any] = json.loads(text)
        self.azimuth = np.array(azimuth, dtype=np.float64)
        self.elevation = np.array(elevation, dtype=np.float64)
        self.lrcs = np.array(lrcs, dtype=np.float64)
        self.by_material = np.array(by_material, dtype=np.float64).reshape(len(self.lrcs), len(parts))
        self.facets_seen = np.array(facets_seen, dtype=np.int64)
        self.parts: List[str] = list(parts)
        self.seconds: float = self.report["seconds"]
        bounds = [a.get("sampling_bound") for a in self.report["aspects"]]
        self.sampling_bound: Optional[np.ndarray] = (
            np.array(bounds, dtype=np.float64) if bounds and all(b is not None for b in bounds) else None
        )
        w = self.report.get("wavelengths_um")
        self.wavelengths: Optional[np.ndarray] = None if w is None else np.array(w, dtype=np.float64)
        self.by_wavelength: Optional[np.ndarray] = (
            None
            if w is None
            else np.array([a["by_wavelength"] for a in self.report["aspects"]], dtype=np.float64).reshape(
                len(self.lrcs), len(w)
            )
        )

    def to_json(self) -> str:
        """The sweep exactly as ``brdf scene lrcs --json`` prints it (without its final newline)."""
        return self._text

    def __repr__(self) -> str:
        return f"SceneLrcs({self.report['scene']!r}, {len(self.lrcs)} aspects, parts {self.parts})"


def scene_lrcs(
    scene, *, visibility: str = "centroid", pixels: Optional[int] = None, supersample: Optional[int] = None
) -> SceneLrcs:
    """Laser radar cross-section of the scene file ``scene`` (TOML: a mesh, a material per
    part, a sensor sweep) at every aspect of its sweep, with each material's exact model
    (f64), as ``brdf scene lrcs``: sigma = sum over the facets seen by source and receiver
    of 4 pi f_r cos(theta_i) cos(theta_r) A. ``visibility``: ``"centroid"`` (a facet counts
    whole when its centroid is seen) or ``"area"`` (the part of each facet seen, as ``brdf
    scene lrcs --visibility area``: each aspect's laser image summed at ``pixels`` along its
    longer side, ``brdf.SWEEP_PIXELS`` unless given, ``supersample`` samples a pixel each
    way, ``brdf.SUPERSAMPLE`` unless given; ``sampling_bound`` then holds each aspect's bound, m^2). Runs on all cores.
    Raises ValueError with the command's message when the scene cannot be used.
    """
    if not isinstance(visibility, str) or visibility not in ("centroid", "area"):
        raise ValueError(f"visibility {visibility!r}: give 'centroid' or 'area'")
    for name, v, most in (("pixels", pixels, _brdf.MAX_PIXELS), ("supersample", supersample, _brdf.MAX_SUPERSAMPLE)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer))):
            raise TypeError(f"{name}: {type(v).__name__} is not a whole number")
        if v is not None and visibility != "area":
            raise ValueError(f"{name} sets the resolution of visibility='area'")
        if v is not None and not 1 <= int(v) <= most:
            raise ValueError(f"{name} {v}: give 1 to {most}")
    area = None
    if visibility == "area":
        area = (
            _brdf.SWEEP_PIXELS if pixels is None else int(pixels),
            _brdf.SUPERSAMPLE if supersample is None else int(supersample),
        )
    return SceneLrcs(*_brdf.scene_lrcs(os.fspath(scene), area))


def scene_domain(scene) -> Dict[str, Any]:
    """Every BRDF query the scene makes, as ``brdf scene domain`` writes it: a dict of
    numpy arrays, one element per (aspect, facet seen), in the command's row order —
    ``azimuth``, ``elevation`` (the aspect, degrees), ``material`` (0-based, scene order:
    the material's index in the blob ``brdf select --scene`` writes), ``part`` (list of
    str), ``facet`` (1-based, mesh order), ``theta_i``, ``theta_r``, ``phi`` (degrees,
    canonical convention, ``phi`` in [0, 180]) and ``weight`` (4 pi cos(theta_i)
    cos(theta_r) A, m^2 sr: sigma at an aspect is the sum of ``weight * brdf`` over its
    queries). Raises ValueError with the command's message when the scene cannot be used.
    """
    az, el, material, part, facet, ti, tr, phi, weight = _brdf.scene_domain(os.fspath(scene))
    f = lambda v: np.array(v, dtype=np.float64)  # noqa: E731
    i = lambda v: np.array(v, dtype=np.int64)  # noqa: E731
    return {
        "azimuth": f(az),
        "elevation": f(el),
        "material": i(material),
        "part": list(part),
        "facet": i(facet),
        "theta_i": f(ti),
        "theta_r": f(tr),
        "phi": f(phi),
        "weight": f(weight),
    }


def scene_profile(scene, bin_m: float, pulse_m: Optional[float] = None) -> Dict[str, Any]:
    """Range profiles of the scene file ``scene``, as ``brdf scene profile`` writes them:
    sigma per range bin of ``bin_m`` metres along the line of sight at every aspect (each
    facet's sigma split over the bins by the share of its area in each; each aspect's bins sum
    to its sigma of :func:`scene_lrcs`), optionally spread by a Gaussian pulse of full width
    at half maximum ``pulse_m``. A dict of numpy arrays, one element per (aspect, bin), in the
    command's row order: ``azimuth``, ``elevation`` (degrees), ``range_m`` (the bin's centre
    beyond the plane through the mesh origin across the line of sight; bistatic, half the
    extra path) and ``lrcs`` (m^2). Raises ValueError with the command's message.
    """
    for name, v in (("bin_m", bin_m), ("pulse_m", pulse_m)):
        # numpy scalars are numbers too (a float32 bin was refused); booleans are not.
        if v is not None and (
            isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating))
        ):
            raise TypeError(f"{name}: {type(v).__name__} is not a length in metres")
    az, el, rng, lrcs = _brdf.scene_profile(
        os.fspath(scene), float(bin_m), None if pulse_m is None else float(pulse_m)
    )
    f = lambda v: np.array(v, dtype=np.float64)  # noqa: E731
    return {"azimuth": f(az), "elevation": f(el), "range_m": f(rng), "lrcs": f(lrcs)}


def scene_image(
    scene, azimuth: Optional[float] = None, elevation: Optional[float] = None, *, pixels: int = _brdf.IMAGE_PIXELS, supersample: int = _brdf.SUPERSAMPLE
) -> Dict[str, Any]:
    """The laser image of the scene file ``scene`` at one aspect (``azimuth`` and
    ``elevation`` in degrees, or the sweep's first), as ``brdf scene image`` draws it: sigma
    per pixel with visibility by the part of each facet seen (a depth buffer of
    ``supersample`` x ``supersample`` samples per pixel along the line of sight), and the
    range of the surface each pixel sees. A dict: ``sigma`` and ``range_m`` (numpy arrays of
    shape (height, width), the top row first; range NaN where nothing is seen),
    ``pixel_m`` (the pixel side), ``origin_m`` (the lower left corner on the image's right and
    up axes through the mesh origin), ``lrcs`` (sigma's sum, m^2) and ``bound`` (the sampling
    bound on it). A scene that lists several wavelengths is refused. Raises ValueError with the command's message.
    """
    for name, v in (("pixels", pixels), ("supersample", supersample)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise TypeError(f"{name}: {type(v).__name__} is not a whole number")
    for name, v in (("azimuth", azimuth), ("elevation", elevation)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating))):
            raise TypeError(f"{name}: {type(v).__name__} is not a number of degrees")
    if int(pixels) < 1 or int(supersample) < 1:
        raise ValueError(f"pixels {pixels}, supersample {supersample}: each at least 1")
    w, h, pixel, sigma, rng, bound, origin = _brdf.scene_image(
        os.fspath(scene),
        None if azimuth is None else float(azimuth),
        None if elevation is None else float(elevation),
        int(pixels),
        int(supersample),
    )
    s = np.array(sigma, dtype=np.float64).reshape(h, w)
    return {
        "sigma": s,
        "range_m": np.array(rng, dtype=np.float64).reshape(h, w),
        "pixel_m": pixel,
        "origin_m": tuple(origin),
        "lrcs": float(s.sum()),
        "bound": bound,
    }


class SceneSelection:
    """What ``brdf select --scene --json`` reports: per material of the scene, every device
    representation (the model ladder fitted to the material at the scene's own queries, the
    six-parameter tables) with its Cortex-M4F instructions per lookup, its blob bytes and
    its worst relative sigma error over the aspects that see it, and the cheapest within
    the budget.

    Attributes: ``materials`` (a dict per material, as in the JSON), ``chosen`` (per
    material, the chosen representation's name or None), ``blob`` (the bytes ``brdf select
    --scene -o`` writes: the chosen set in scene order, or None), ``blob_note`` (why there
    is no blob), ``report`` (the whole JSON as a dict). ``to_json()`` is the text the
    command prints for the same scene, budget and seed.
    """

    def __init__(self, text: str, blob: Optional[bytes], blob_note: Optional[str]):
        self._text = text
        self.report: Dict[str, Any] = json.loads(text)
        self.materials: List[Dict[str, Any]] = self.report["materials"]
        self.chosen: List[Optional[str]] = [
            None if m["chosen"] is None else m["candidates"][m["chosen"]]["name"] for m in self.materials
        ]
        self.blob: Optional[bytes] = blob
        self.blob_note: Optional[str] = blob_note

    def to_json(self) -> str:
        """The selection exactly as ``brdf select --scene --json`` prints it (without its final newline)."""
        return self._text

    def __repr__(self) -> str:
        return f"SceneSelection({self.report['scene']!r}, chosen: {self.chosen})"


def select_scene(
    scene, *, budget: float = 0.02, seed: int = 1, sequence: int = 1, allow_nonphysical: bool = False
) -> SceneSelection:
    """Per material of the scene file ``scene``, the cheapest device representation whose
    sigma stays within ``budget`` (a fraction: 0.01 is 1%; at most 1) of the exact model's at every
    aspect that sees it, as ``brdf select --scene``; ``seed`` seeds the ladder's fits,
    ``sequence`` is the blob's sequence number and ``allow_nonphysical`` also lets models that
    are not reciprocal or unbounded at grazing be chosen (``--allow-nonphysical``). Raises
    ValueError with the command's message when the scene cannot be used.
    """
    if not isinstance(allow_nonphysical, bool):
        raise TypeError(f"allow_nonphysical must be True or False, not {allow_nonphysical!r}")
    sequence = _whole("sequence", sequence)
    if not 0 <= sequence <= 0xFFFFFFFF:
        raise ValueError(f"sequence {sequence}: outside 0..=4294967295")
    seed = _whole("seed", seed)
    if not 0 <= seed <= 0xFFFFFFFFFFFFFFFF:
        raise ValueError(f"seed {seed}: outside 0..=18446744073709551615")
    return SceneSelection(
        *_brdf.select_scene(os.fspath(scene), _number("budget", budget), seed, sequence, allow_nonphysical)
    )
