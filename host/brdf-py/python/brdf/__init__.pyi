from typing import Any, Dict, List, Mapping, Optional, Sequence, Union, overload
import os

import numpy as np
import numpy.typing as npt

Params = Union[str, Mapping[str, float]]
ArrayLike = npt.ArrayLike

MODELS: List[str]
SWEEP_PIXELS: int
IMAGE_PIXELS: int
SUPERSAMPLE: int

def eval(
    model: str,
    params: Params,
    theta_i: ArrayLike,
    theta_r: ArrayLike,
    phi: ArrayLike,
    *,
    precision: str = "f64",
    parallel: bool = True,
) -> Union[np.ndarray, np.floating]: ...
def eval_fit(
    fit: Union["FitResult", Sequence["FitResult"], str, os.PathLike],
    theta_i: ArrayLike,
    theta_r: ArrayLike,
    phi: ArrayLike,
    *,
    index: Optional[int] = None,
    wavelength: Optional[ArrayLike] = None,
    precision: str = "f64",
    parallel: bool = True,
) -> Union[np.ndarray, np.floating]: ...
def eval_cosines(
    model: str,
    params: Params,
    cos_theta_i: ArrayLike,
    cos_theta_r: ArrayLike,
    cos_phi: ArrayLike,
    *,
    precision: str = "f64",
    parallel: bool = True,
) -> Union[np.ndarray, np.floating]: ...
def eval_vectors(
    model: str,
    params: Params,
    wi: ArrayLike,
    wr: ArrayLike,
    *,
    precision: str = "f64",
    parallel: bool = True,
) -> Union[np.ndarray, np.floating]: ...

def albedo(model: str, params: Params, theta_i: ArrayLike, *, panels: Optional[int] = None) -> Union[np.ndarray, np.floating]: ...

class FitResult:
    report: Mapping[str, Any]
    dataset: str
    wavelength: Optional[float]
    model: str
    params: Mapping[str, float]
    std_errors: Mapping[str, Optional[float]]
    undetermined: Mapping[str, str]
    correlation: Any
    metrics: Mapping[str, float]
    energy: Mapping[str, Any]
    converged: bool
    def __init__(self, text: str) -> None: ...
    def to_json(self) -> str: ...
    def eval(
        self,
        theta_i: ArrayLike,
        theta_r: ArrayLike,
        phi: ArrayLike,
        *,
        precision: str = "f64",
        parallel: bool = True,
    ) -> Union[np.ndarray, np.floating]: ...

def fit(
    data: Union[str, os.PathLike, Sequence[Union[str, os.PathLike]], Mapping[str, ArrayLike], Any],
    model: str = "six",
    *,
    seed: int = 1,
    residual: str = "relative",
    engine: str = "full",
    **options: Any,
) -> Union[FitResult, List[FitResult]]: ...
def read(
    path: Union[str, os.PathLike],
    format: Optional[str] = None,
    channel: Optional[str] = None,
    *,
    band: Optional[float] = None,
    skip_invalid: bool = False,
) -> List[Dict[str, Any]]: ...
class Selection:
    report: Dict[str, Any]
    dataset: str
    wavelength: Optional[float]
    budget: float
    n: int
    chosen: Optional[str]
    within_budget: bool
    reason: str
    candidates: List[FitResult]
    chosen_fit: Optional[FitResult]
    representations: List[Dict[str, Any]]
    blob: Optional[bytes]
    def __init__(self, text: str, candidates: Sequence[str], blob: Optional[bytes]) -> None: ...
    def to_json(self) -> str: ...

def select(
    data: Union[str, os.PathLike, Mapping[str, ArrayLike], Any],
    *,
    budget: float = 0.02,
    max_theta: float = 90.0,
    max_theta_i: Optional[float] = None,
    max_theta_r: Optional[float] = None,
    allow_nonphysical: bool = False,
    sequence: int = 1,
    seed: int = 1,
    residual: str = "relative",
    **options: Any,
) -> Selection: ...
def to_json(results: Union[FitResult, Sequence[FitResult]]) -> str: ...
def pack(
    results: Union[FitResult, str, os.PathLike, Sequence[Union[FitResult, str, os.PathLike]]],
    table_nodes: Optional[int] = None,
    *,
    sequence: int = 1,
) -> bytes: ...
class SceneLrcs:
    report: Dict[str, Any]
    azimuth: np.ndarray
    elevation: np.ndarray
    lrcs: np.ndarray
    by_material: np.ndarray
    facets_seen: np.ndarray
    parts: List[str]
    seconds: float
    sampling_bound: Optional[np.ndarray]
    def __init__(
        self,
        text: str,
        azimuth: Sequence[float],
        elevation: Sequence[float],
        lrcs: Sequence[float],
        by_material: Sequence[Sequence[float]],
        facets_seen: Sequence[int],
        parts: Sequence[str],
    ) -> None: ...
    def to_json(self) -> str: ...

def scene_lrcs(
    scene: Union[str, os.PathLike],
    *,
    visibility: str = "centroid",
    pixels: Optional[int] = None,
    supersample: Optional[int] = None,
) -> SceneLrcs: ...
def scene_domain(scene: Union[str, os.PathLike]) -> Dict[str, Any]: ...
def scene_profile(
    scene: Union[str, os.PathLike], bin_m: float, pulse_m: Optional[float] = None
) -> Dict[str, Any]: ...
def scene_image(
    scene: Union[str, os.PathLike],
    azimuth: Optional[float] = None,
    elevation: Optional[float] = None,
    *,
    pixels: int = ...,
    supersample: int = ...,
) -> Dict[str, Any]: ...
class SceneSelection:
    report: Dict[str, Any]
    materials: List[Dict[str, Any]]
    chosen: List[Optional[str]]
    blob: Optional[bytes]
    blob_note: Optional[str]
    def __init__(self, text: str, blob: Optional[bytes], blob_note: Optional[str]) -> None: ...
    def to_json(self) -> str: ...

def select_scene(
    scene: Union[str, os.PathLike],
    *,
    budget: float = 0.02,
    seed: int = 1,
    sequence: int = 1,
    allow_nonphysical: bool = False,
) -> SceneSelection: ...
