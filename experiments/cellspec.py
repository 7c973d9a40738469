"""The cell boundary: what the runner hands a cell process (:class:`CellSpec`) and what comes back
(:class:`CellOutcome`). Both cross a process boundary as JSON (a worker's request and answer lines, a Dask task's
argument and result); ``to_dict``/``from_dict`` are their only wire forms."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

__all__ = ["CellDataset", "CellMethod", "CellSpec", "CellOutcome", "STATUSES"]

#: what became of a cell: ok, or why not
STATUSES = ("ok", "error", "timeout", "killed", "disk_full")


@dataclass(frozen=True)
class CellDataset:
    name: str
    params: dict
    label: str
    simulator: bool
    #: the landmark extraction applied after loading (DatasetSpec.landmarks), None: none
    landmarks: dict | None = None


@dataclass(frozen=True)
class CellMethod:
    name: str
    params: dict
    label: str


@dataclass(frozen=True)
class CellSpec:
    """One cell to run: where its files go, its cache keys, the dataset and method with their config parameters, the
    seed (passed to a simulator; to the method only if ``seed_to_estimator``), the metric settings, the environment
    variables of its process, and whether to recompute a cached estimate (``force``) and write ``result.mcap``."""

    id: str
    dir: str
    key: str
    metrics_key: str
    seed: int
    dataset: CellDataset
    estimator: CellMethod
    seed_to_estimator: bool
    metrics: dict[str, dict]
    env: dict[str, str] = field(default_factory=dict)
    force: bool = False
    mcap: bool = False

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> CellSpec:
        return cls(**{**d, "dataset": CellDataset(**d["dataset"]), "estimator": CellMethod(**d["estimator"])})


@dataclass(frozen=True)
class CellOutcome:
    """What became of a cell process: ``status`` one of :data:`STATUSES`, the error and traceback of one that is not
    ok, its wall time and the seconds numba spent compiling in it."""

    id: str
    status: str = "ok"
    error: str = ""
    traceback: str = ""
    elapsed: float = 0.0
    compile_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> CellOutcome:
        return cls(**d)
