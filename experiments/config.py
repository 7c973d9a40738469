"""Experiment configs: a YAML file validated by pydantic before anything runs.

An experiment is the grid datasets × estimators × seeds, the metrics to compute on every
cell, the tables and figures to write, where to write them and a per-cell timeout::

    name: default                     # results go to <output>, default results/<name>
    seeds: 3                          # a count (0, 1, 2) or a list [0, 7, 42]
    timeout: 600                      # seconds per cell (null: none)
    single_threaded: false            # true: one BLAS/OpenMP/numba thread per cell (cost studies)
    datasets:
      - name: sim:landmarks           # a registry name (slamarena.datasets.load)
        params: {n_landmarks: 50}     # keyword arguments; a simulator's seed is the cell's seed
        label: lm50                   # optional directory/table name (default: sanitised name)
      - name: utias                   # a format family with the path of a recording (or utias:<dir>/robot<k>)
        params: {path: /data/MRCLAM_Dataset7, robot: 1}
        label: mrclam7_robot1
      - name: carpark                 # raw scans: landmarks extracted before the methods run
        landmarks: {features: beacons}  # mapping.landmark_extraction.ExtractionParams (its range-bearing stream)
    estimators:
      - name: dead_reckoning          # estimators.REGISTRY or mapping.REGISTRY
        params: {motion_model: arc}   # constructor keywords, checked by constructing the class
        datasets: [lm50]              # optional: only these dataset labels (default: every dataset)
    metrics:                          # metric name → parameters (slamarena.experiments.metrics.METRICS)
      ate: {align: se2}
      nees: {}
    tables:
      - name: accuracy
        columns: [ate.rmse, rpe.trans_rmse, cost.step_median]
    figures: [trajectories, errors, nees, scaling]
    claims:                           # the findings its pages state, checked on every run (slamarena.experiments.claims)
      - claim: dead reckoning drifts by less than a metre on the 50-landmark world
        column: ate.rmse
        rows: lm50/dead_reckoning     # DATASET/ESTIMATOR shell patterns
        below: 1.0                    # or {estimator: LABEL, times: F} (another row); above: likewise
    protocol:                         # optional: leave-one-log-out choice of parameters (slamarena.experiments.protocol)
      score: [relations.trans_mean, refrel.trans_mean]
      candidates: {grid_slam: [grid_slam_w10, grid_slam_w100]}   # method → its candidates' estimator labels

Every mistake — an unknown key, a wrong type or value, an unregistered dataset or method, a
parameter the simulator/reader/estimator does not take or rejects, a claim on a column or row the run will not
have — is a :class:`ConfigError` whose message names the field path (e.g. ``estimators.0.params``).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)

from slamarena.errors import UserError
from slamarena.params import describe_error, params_model
from slamarena.targets import import_target

from .claims import Claim
from .metrics import METRICS, output_columns
from .protocol import ProtocolSpec

__all__ = [
    "ExperimentConfig",
    "Claim",
    "PublishedRow",
    "DatasetSpec",
    "EstimatorSpec",
    "TableSpec",
    "MetricsSpec",
    "ConfigError",
    "load_config",
    "shipped_configs",
    "sanitize",
    "method_table",
    "FIGURES",
]

#: figure kinds a config may ask for (implemented one module each in ``paper_figures``)
FIGURES = ("trajectories", "errors", "nees", "scaling", "relations", "neff", "maps", "vo")


class ConfigError(UserError, ValueError):
    """An experiment config that cannot run; the message lists every problem with its field path."""


def sanitize(name: str) -> str:
    """A dataset or method name as a directory name: ``utias:6/robot1`` → ``utias_6_robot1``."""
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", name).strip("_")


def require_plain(name: str | None, what: str, kind: str = "directory") -> str | None:
    """``name`` unchanged if it is usable as a file or directory name as it is, else a ValueError."""
    if name is not None and sanitize(name) != name:
        raise ValueError(f"{what} {name!r} must be a plain {kind} name, e.g. {sanitize(name)!r}")
    return name


def method_table() -> dict[str, str]:
    """Every runnable method: ``slamarena.estimators.REGISTRY`` merged with ``slamarena.mapping.REGISTRY``."""
    from slamarena.estimators import REGISTRY as ESTIMATORS
    from slamarena.mapping import REGISTRY as MAPPERS

    return {**ESTIMATORS, **MAPPERS}


def method_requires() -> dict[str, tuple[frozenset[str], ...]]:
    """Every method's needed input streams (the registries' ``REQUIRES``)."""
    from slamarena.estimators import REQUIRES as ESTIMATORS
    from slamarena.mapping import REQUIRES as MAPPERS

    return {**ESTIMATORS, **MAPPERS}


def resolve_params(target, params: dict, what: str, reserved: tuple[str, ...] = ()) -> dict:
    """``params`` validated by the ``Params`` model ``target`` declares (:mod:`slamarena.params`), as its
    canonical JSON form with every default filled in; a ValueError naming each offending ``params.<field>``."""
    for key in reserved:
        if key in params:
            raise ValueError(f"{what}: params.{key} is set by the runner (from seeds:), not in params")
    try:
        return params_model(target).of(params).canonical()
    except ValidationError as exc:
        raise ValueError(f"{what}: {problems(exc)}") from None


def problems(exc: ValidationError) -> str:
    """Each error of a parameter model's validation as ``params.<field>: message`` (an unknown key with the
    closest valid ones: :func:`slamarena.params.describe_error`)."""
    return "; ".join(describe_error(e) for e in exc.errors())


class DatasetSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str
    params: dict[str, Any] = Field(default_factory=dict)
    label: str | None = None
    #: landmarks extracted from the dataset's scans (mapping.landmark_extraction.ExtractionParams) as its range-bearing
    #: stream, before any method runs; None: the dataset as read
    landmarks: dict[str, Any] | None = None

    _resolved: dict = PrivateAttr(default_factory=dict)
    _landmarks: dict | None = PrivateAttr(default=None)

    def resolved_params(self) -> dict:
        """Every parameter of the dataset, defaults filled in (its reader's or simulator's ``Params`` model)."""
        return self._resolved

    def resolved_landmarks(self) -> dict | None:
        """The extraction's parameters with its defaults filled in (None: no extraction)."""
        return self._landmarks

    @property
    def is_simulator(self) -> bool:
        from slamarena.datasets.registry import SIMULATORS

        return self.name in SIMULATORS

    @model_validator(mode="after")
    def _registered(self):
        from slamarena.datasets.registry import SIMULATORS, resolve

        if self.name in SIMULATORS:
            try:
                simulate = import_target(SIMULATORS[self.name])
            except ImportError as exc:
                raise ValueError(f"simulator {self.name!r} is registered but cannot be imported: {exc}") from None
            self._resolved = resolve_params(simulate, self.params, f"dataset {self.name!r}", reserved=("seed",))
        else:  # a catalogued name, or a format family with a path (slamarena.datasets.registry.resolve)
            try:
                self._resolved = resolve(self.name, self.params).params.canonical()
            except ValidationError as exc:
                raise ValueError(f"dataset {self.name!r}: {problems(exc)}") from None
            except ImportError as exc:
                raise ValueError(f"dataset {self.name!r}: its reader cannot be imported: {exc}") from None
            except (
                UserError
            ) as exc:  # an unknown name, a location a catalogued name fixes, a path not in the family's form
                raise ValueError(str(exc)) from None
        if self.landmarks is not None:
            from slamarena.mapping.landmark_extraction import extract

            self._landmarks = resolve_params(extract, self.landmarks, f"dataset {self.name!r} landmarks")
        require_plain(self.label, "label")
        return self


class EstimatorSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str
    params: dict[str, Any] = Field(default_factory=dict)
    label: str | None = None
    datasets: list[str] | None = Field(None, description="dataset labels this method runs on (default: all)")
    _resolved: dict = PrivateAttr(default_factory=dict)

    @field_validator("datasets")
    @classmethod
    def _not_empty(cls, datasets):
        if datasets is not None and not datasets:
            raise ValueError(
                "an empty list runs the method on no dataset; leave 'datasets' out to run it on every dataset, "
                "or remove the method"
            )
        return datasets

    @model_validator(mode="after")
    def _registered(self):
        table = method_table()
        if self.name not in table:
            raise ValueError(f"unknown method {self.name!r}; registered: {', '.join(sorted(table))}")
        try:
            cls = import_target(table[self.name])
        except (ImportError, AttributeError) as exc:
            raise ValueError(
                f"method {self.name!r} is registered ({table[self.name]}) but cannot be imported: {exc}"
            ) from None
        self._resolved = resolve_params(cls, self.params, f"method {self.name!r}")
        require_plain(self.label, "label")
        return self

    def takes_seed(self) -> bool:
        """Whether the runner passes the cell's seed: the method's parameters have one and the config does not fix it."""
        return (
            "seed" in params_model(import_target(method_table()[self.name])).model_fields and "seed" not in self.params
        )

    def resolved_params(self) -> dict:
        """Every parameter of the method, defaults filled in (its ``Params`` model's canonical form)."""
        return self._resolved


MetricsSpec = create_model(
    "MetricsSpec",
    __config__=ConfigDict(extra="forbid"),
    **{name: (m.params | None, None) for name, m in METRICS.items()},
)
MetricsSpec.__doc__ = "Metric name → parameters; a metric left out is not computed."


def _default_metrics():
    return MetricsSpec(ate={}, rpe={}, nees={}, nis={}, map={}, cost={})


class TableSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str
    columns: list[str] = Field(min_length=1)
    formats: list[Literal["md", "csv", "tex"]] = ["md", "csv", "tex"]

    @field_validator("columns")
    @classmethod
    def _known(cls, columns):
        known = output_columns()
        for c in columns:
            if c not in known:
                raise ValueError(
                    f"unknown column {c!r}; columns are <metric>.<output>, e.g. {', '.join(list(known)[:6])}, …"
                )
        return columns

    @field_validator("name")
    @classmethod
    def _plain(cls, name):
        return require_plain(name, "table name", kind="file")


class PublishedRow(BaseModel):
    """A reference row quoted from a paper, printed beside ours in every table that has its columns."""

    model_config = ConfigDict(extra="forbid")
    label: str = Field(description="the method as the paper names it, e.g. 'graph mapping (Kümmerle 2009)'")
    citation: str = Field(description="where the numbers are printed (paper, table)")
    values: dict[str, dict[str, float]] = Field(
        description="dataset label → column (<metric>.<output>) → the published value"
    )

    @field_validator("values")
    @classmethod
    def _known_columns(cls, values):
        known = output_columns()
        for dataset, columns in values.items():
            for c in columns:
                if c not in known:
                    raise ValueError(f"values.{dataset}: unknown column {c!r}; columns are <metric>.<output>")
        return values


class ExperimentConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str
    description: str = ""
    datasets: list[DatasetSpec] = Field(min_length=1)
    estimators: list[EstimatorSpec] = Field(min_length=1)
    seeds: int | list[int] = 1
    metrics: MetricsSpec = Field(default_factory=_default_metrics)  # type: ignore[valid-type]
    tables: list[TableSpec] = Field(default_factory=list)
    figures: list[Literal[FIGURES]] = list(FIGURES)  # type: ignore[valid-type]
    published: list[PublishedRow] = Field(
        default_factory=list, description="reference rows quoted from papers, shown beside ours"
    )
    claims: list[Claim] = Field(
        default_factory=list,
        description="the findings its pages state, each a bound on a column; checked after a run and by "
        "`slamarena results` (slamarena.experiments.claims)",
    )
    output: Path | None = None
    timeout: float | None = Field(600.0, gt=0, description="seconds per cell; null for none")
    mcap: bool = Field(
        False,
        description="every computed cell also writes result.mcap (trajectory, tf, its grid or landmarks) for Foxglove",
    )
    single_threaded: bool = Field(
        False,
        description="run every cell with BLAS, OpenMP and numba limited to one thread, so that cost "
        "measurements compare algorithms, not thread counts (cost studies)",
    )
    protocol: ProtocolSpec | None = Field(
        None, description="leave-one-log-out choice of each method's parameters among its candidate entries"
    )

    @field_validator("metrics", mode="before")
    @classmethod
    def _metric_list(cls, metrics):
        """``metrics: [ate, rpe]`` is short for ``metrics: {ate: {}, rpe: {}}``."""
        if isinstance(metrics, list) and all(isinstance(m, str) for m in metrics):
            return {m: {} for m in metrics}
        return metrics

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, seeds):
        if isinstance(seeds, int):
            if seeds < 1:
                raise ValueError("a seed count must be ≥ 1")
            return seeds
        if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
            raise ValueError("seeds must be a non-empty list of distinct non-negative integers")
        return seeds

    @field_validator("name")
    @classmethod
    def _plain(cls, name):
        return require_plain(name, "experiment name")

    @model_validator(mode="after")
    def _consistent(self):
        for kind, labels in (("dataset", self.dataset_labels()), ("estimator", self.estimator_labels())):
            dup = sorted({x for x in labels if labels.count(x) > 1})
            if dup:
                raise ValueError(f"{kind} labels must be unique; give entries a distinct 'label': {', '.join(dup)}")
        labels = self.dataset_labels()
        for k, es in enumerate(self.estimators):
            unknown = sorted(set(es.datasets or []) - set(labels))
            if unknown:
                raise ValueError(
                    f"estimators.{k}.datasets names unknown dataset labels {unknown}; labels are: {', '.join(labels)}"
                )
        requires = method_requires()
        from slamarena.datasets.streams import streams_of

        for k, es in enumerate(self.estimators):
            for label, ds in zip(labels, self.datasets):
                if es.datasets is not None and label not in es.datasets:
                    continue
                have = streams_of(ds.name, ds.params)
                if ds.landmarks is not None and have:
                    if "scans" not in have:
                        raise ValueError(
                            f"datasets: {label!r} has landmarks to extract but {ds.name} has no scans "
                            f"({', '.join(sorted(have))})"
                        )
                    have = have | {"range_bearing"}
                missing = [
                    " or ".join(sorted(group)) for group in requires.get(es.name, ()) if have and not group & have
                ]
                if missing:
                    raise ValueError(
                        f"estimators.{k} ({es.name}) cannot run on dataset {label!r}: it needs {' and '.join(missing)}, which "
                        f"{ds.name} does not provide ({', '.join(sorted(have))}); restrict it with 'datasets: [...]'"
                    )
        for k, row in enumerate(self.published):
            unknown = sorted(set(row.values) - set(labels))
            if unknown:
                raise ValueError(
                    f"published.{k} ({row.label}) names unknown dataset labels {unknown}; labels are: {', '.join(labels)}"
                )
        for k, claim in enumerate(self.claims):
            try:
                claim.validate_against(self.cell_keys())
            except ValueError as exc:
                raise ValueError(f"claims.{k}: {exc}") from None
        enabled = {k for k, v in self.metrics if v is not None}
        for k, table in enumerate(self.tables):
            missing = sorted({c.split(".")[0] for c in table.columns} - enabled)
            if missing:
                raise ValueError(
                    f"tables.{k} ({table.name}) uses metrics that are not enabled under metrics: {', '.join(missing)}"
                )
        if self.protocol is not None:
            self._check_protocol(enabled)
        return self

    def _check_protocol(self, enabled: set[str]) -> None:
        """The protocol's score columns are known, lower-is-better outputs of enabled metrics; each method's candidates
        are at least two estimator labels of that method, none in two groups, each run on every dataset."""
        known = output_columns()
        for c in self.protocol.score:
            if c not in known or known[c][0] != "lower":
                raise ValueError(f"protocol.score: {c!r} is not a lower-is-better column <metric>.<output>")
            if c.split(".")[0] not in enabled:
                raise ValueError(f"protocol.score: {c!r} needs metric {c.split('.')[0]!r} enabled under metrics")
        by_label = dict(zip(self.estimator_labels(), self.estimators))
        seen: set[str] = set()
        for method, labels in self.protocol.candidates.items():
            where = f"protocol.candidates.{method}"
            if len(labels) < 2 or len(set(labels)) != len(labels):
                raise ValueError(f"{where}: at least two distinct candidate labels")
            for label in labels:
                if label not in by_label:
                    raise ValueError(f"{where}: {label!r} is no estimator label; labels are: {', '.join(by_label)}")
                if label in seen:
                    raise ValueError(f"{where}: {label!r} is a candidate of two methods")
                if by_label[label].name != method:
                    raise ValueError(f"{where}: {label!r} is method {by_label[label].name!r}, not {method!r}")
                if by_label[label].datasets is not None:
                    raise ValueError(f"{where}: {label!r} must run on every dataset (no 'datasets:' list)")
            seen.update(labels)

    # ------------------------------------------------------------------ derived
    def seed_list(self) -> list[int]:
        return list(range(self.seeds)) if isinstance(self.seeds, int) else list(self.seeds)

    def dataset_labels(self) -> list[str]:
        return [d.label or sanitize(d.name) for d in self.datasets]

    def estimator_labels(self) -> list[str]:
        return [e.label or sanitize(e.name) for e in self.estimators]

    def cell_keys(self) -> set[str]:
        """``dataset/estimator`` of every (dataset, method) pair of the grid (a method's ``datasets:`` respected)."""
        return {
            f"{d}/{e}"
            for e, es in zip(self.estimator_labels(), self.estimators)
            for d in self.dataset_labels()
            if es.datasets is None or d in es.datasets
        }

    def enabled_metrics(self) -> dict[str, BaseModel]:
        return {k: v for k, v in self.metrics if v is not None}

    def reduced(
        self,
        datasets: list[str] | None = None,
        estimators: list[str] | None = None,
        seeds: int | list[int] | None = None,
    ) -> ExperimentConfig:
        """The same experiment on a part of its grid (the studies' slow tests run a shipped config this way): only the
        dataset and method labels named, ``seeds`` in place of the config's; tables, metrics and published rows as they
        are (those of a dropped dataset dropped), the claims whose rows and references are all still in the grid.
        Validated again."""
        raw = self.model_dump(mode="json", exclude_unset=True)
        keep_ds = set(datasets or self.dataset_labels())
        keep_es = set(estimators or self.estimator_labels())
        raw["datasets"] = [d for d, label in zip(raw["datasets"], self.dataset_labels()) if label in keep_ds]
        raw["estimators"] = [e for e, label in zip(raw["estimators"], self.estimator_labels()) if label in keep_es]
        for e in raw["estimators"]:
            if e.get("datasets") is not None:
                e["datasets"] = [d for d in e["datasets"] if d in keep_ds]
        raw["estimators"] = [e for e in raw["estimators"] if e.get("datasets") != []]
        for row in raw.get("published", []):
            row["values"] = {d: v for d, v in row["values"].items() if d in keep_ds}
        kept = {f"{d}/{e}" for d, e in (k.split("/") for k in self.cell_keys()) if d in keep_ds and e in keep_es}
        raw["claims"] = [c.model_dump(mode="json") for c in self.claims if c.applies(kept)]
        if raw.get("protocol") is not None:
            labels = {e.get("label") or sanitize(e["name"]) for e in raw["estimators"]}
            groups = {m: [c for c in cs if c in labels] for m, cs in raw["protocol"]["candidates"].items()}
            groups = {m: cs for m, cs in groups.items() if len(cs) >= 2}
            raw["protocol"] = {**raw["protocol"], "candidates": groups} if groups else None
        if seeds is not None:
            raw["seeds"] = seeds
        return ExperimentConfig.model_validate(raw)

    def output_dir(self, override: Path | None = None) -> Path:
        return Path(override) if override is not None else (self.output or Path("results") / self.name)


def shipped_configs() -> dict[str, str]:
    """The shipped configs (``experiments/configs/*.yaml``): name → the config's one-line ``description``, read
    without validating (listing must not need the data a config names)."""
    from importlib.resources import files

    import yaml

    shipped = files("slamarena.experiments").joinpath("configs")
    out = {}
    for entry in sorted(shipped.iterdir(), key=lambda p: p.name):
        if entry.name.endswith(".yaml"):
            raw = yaml.safe_load(entry.read_text()) or {}
            out[entry.name.removesuffix(".yaml")] = str(raw.get("description", "")).strip()
    return out


def _duplicate_keys(node, path: tuple[str, ...] = ()):
    """Each key given twice in one mapping of a composed YAML document: (its field path, its line, the first line)."""
    import yaml

    if isinstance(node, yaml.MappingNode):
        first: dict[str, int] = {}
        for key, value in node.value:
            line = key.start_mark.line + 1
            if key.value in first:
                yield (*path, str(key.value)), line, first[key.value]
            else:
                first[key.value] = line
            yield from _duplicate_keys(value, (*path, str(key.value)))
    elif isinstance(node, yaml.SequenceNode):
        for k, item in enumerate(node.value):
            yield from _duplicate_keys(item, (*path, str(k)))


def _estimators_from(raw: dict, where: str, via: tuple[str, ...]) -> list[EstimatorSpec]:
    """``estimators_from: NAME`` runs another shipped config's estimator rows unchanged (the same methods on other data,
    e.g. a withheld dataset); it replaces ``estimators``. ``via``: the configs that led here (a cycle is an error)."""
    source = raw.pop("estimators_from")
    if "estimators" in raw:
        raise ConfigError(f"{where}: estimators_from: give the estimator rows or estimators_from, not both")
    if not isinstance(source, str) or Path(source).name != source or Path(source).suffix:
        raise ConfigError(f"{where}: estimators_from: the name of a shipped config (e.g. mrclam), not {source!r}")
    if source in via:
        raise ConfigError(f"{where}: estimators_from: {source} leads back to itself ({' → '.join((*via, source))})")
    try:
        estimators = load_config(source, _via=(*via, source)).estimators
    except ConfigError as exc:
        raise ConfigError(f"{where}: estimators_from: {exc}") from None
    return estimators


def load_config(path: str | Path | None = None, _via: tuple[str, ...] = ()) -> ExperimentConfig:
    """Read and validate an experiment YAML: a path, or the name of a shipped config
    (``experiments/configs/<name>.yaml``); ``None`` → the shipped ``default``. ``estimators_from: NAME`` takes the
    named shipped config's estimator rows."""
    from importlib.resources import files

    import yaml

    shipped = files("slamarena.experiments").joinpath("configs")
    name = "default" if path is None else str(path)
    bare = path is None or (
        Path(name).name == name and not Path(name).suffix
    )  # "scaling", not "scaling.yaml" or "dir/x"
    if path is not None and Path(path).is_file():
        blob, where = Path(path).read_bytes(), str(path)
    elif bare and shipped.joinpath(f"{name}.yaml").is_file():
        blob, where = shipped.joinpath(f"{name}.yaml").read_bytes(), f"{name}.yaml (shipped)"
    else:
        names = sorted(p.name.removesuffix(".yaml") for p in shipped.iterdir() if p.name.endswith(".yaml"))
        raise ConfigError(
            f"{path}: no such config file (a shipped config is named without a suffix: {', '.join(names)})"
        )
    try:
        text = blob.decode("utf-8-sig")  # a byte order mark, if an editor wrote one, is not part of the YAML
    except UnicodeDecodeError as exc:
        line = blob[: exc.start].count(b"\n") + 1
        raise ConfigError(
            f"{where}:{line}: not UTF-8 text (byte {blob[exc.start]:#04x} at offset {exc.start}); save the config as UTF-8"
        ) from None
    try:
        duplicate = next(_duplicate_keys(yaml.compose(text, Loader=yaml.SafeLoader)), None)
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{where}: not valid YAML: {exc}") from None
    if duplicate is not None:
        key_path, line, first = duplicate
        raise ConfigError(
            f"{where}:{line}: {'.'.join(key_path)}: a key given twice (first on line {first}); YAML would keep the last "
            "silently: remove one"
        )
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: an experiment config is a mapping (name, datasets, estimators, …)")
    if "estimators_from" in raw:
        raw["estimators"] = _estimators_from(raw, where, _via or ((name,) if where.endswith("(shipped)") else ()))
    try:
        return ExperimentConfig.model_validate(raw)
    except ValidationError as exc:
        lines = []
        for e in exc.errors():
            loc = ".".join(str(x) for x in e["loc"] if not str(x).startswith("function-"))
            msg = e["msg"].removeprefix("Value error, ")
            lines.append(f"  {loc or '(top level)'}: {msg}")
        raise ConfigError(f"{where}: invalid experiment config\n" + "\n".join(lines)) from None
