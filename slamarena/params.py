"""Typed parameters: one pydantic model per method, matcher, reader and simulator, declared beside it.

Every configurable thing in slamarena declares its parameters once, as a subclass of :class:`Params`:
choices as ``Literal``, ranges as constraints, units in each field's description. The model is the single
source of the parameter names, defaults and rules; the object built from it keeps the validated model as
``self.params``::

    class DeadReckoningParams(Params):
        motion_model: Literal["arc", "euler"] = Field("arc", description="motion model (estimators.models)")

    class DeadReckoning:
        Params = DeadReckoningParams

        def __init__(self, params: DeadReckoningParams | None = None, /, **overrides):
            self.params = self.Params.of(params, overrides)

Functions (simulators, readers) declare theirs with :func:`with_params`::

    @with_params(LandmarkWorldParams)
    def simulate(params: LandmarkWorldParams) -> Sequence: ...

    simulate(n_landmarks=200, seed=3)          # keywords are validated into the model

In both cases ``DeadReckoning(motion_model="euler")`` and ``DeadReckoning(DeadReckoningParams(motion_model="euler"))``
are the same object, and ``DeadReckoning(motion_model="eular")`` raises :class:`pydantic.ValidationError`
naming the field. An experiment config validates a method's ``params:`` by the same model before any cell
runs, and a cell's cache key hashes :meth:`Params.canonical` (defaults included, so changing a default
recomputes what it changes). Covariances are given as a scalar, the diagonal or the full matrix and are
stored as the full matrix (:func:`covariance`), so two spellings of one covariance hash alike.

A method's parameters are composed of sub-models, one per part, as kiss-icp composes ``data`` / ``mapping`` /
``registration``: laser graph SLAM's ``LaserSLAMParams`` holds ``frontend`` (a ``FrontEndParams``), ``pyramid`` (a
``PyramidParams`` holding ``cells``), ``loop`` and ``refine``, and each part's driver is handed its sub-model by
attribute (``LoopCloser(params.loop)``). A sub-model given as a mapping is laid over the field's default, so
``loop: {level: 2}`` changes the loop search's level and keeps the method's other loop settings (also where the
method's default differs from the sub-model's own, e.g. the RBPF's ``pyramid.cells.hit_guard = 1``). A key that
is not a parameter is an error naming the closest valid ones with their paths (``loop_level`` → ``loop.level``):
the flat names of earlier versions are refused, never silently aliased. ``research/method/parameters.md`` has the
structure; ``slamarena params METHOD`` prints a method's tree with defaults, units and descriptions.
"""

from __future__ import annotations

import difflib
import functools
from collections.abc import Callable, Iterator, Mapping
from typing import Annotated, Any, Self

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError, ValidationError
from pydantic_core.core_schema import ErrorType

ERROR_TYPES = frozenset(ErrorType.__args__)

__all__ = [
    "Params",
    "describe_error",
    "parameter_paths",
    "covariance",
    "Covariance2",
    "Covariance3",
    "Probability",
    "params_model",
    "with_params",
    "Field",
]


class Params(BaseModel):
    """Base of every parameter model: unknown keys are errors, defaults are validated, instances are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)

    @model_validator(mode="wrap")
    @classmethod
    def _laid_over_defaults_and_checked(cls, data: Any, handler) -> Any:
        """Lay each sub-model given as a mapping over its default; an unknown key's error names the closest paths."""
        if isinstance(data, Mapping):
            data = {
                name: _laid_over(cls.model_fields[name].default, value)
                if name in cls.model_fields
                and isinstance(cls.model_fields[name].default, Params)
                and isinstance(value, Mapping)
                else value
                for name, value in data.items()
            }
        try:
            return handler(data)
        except ValidationError as exc:
            if not any(e["type"] == "extra_forbidden" and len(e["loc"]) == 1 for e in exc.errors()):
                raise
            raise ValidationError.from_exception_data(
                cls.__name__, [_suggesting(cls, e) for e in exc.errors()]
            ) from None

    @classmethod
    def of(cls, params: Params | Mapping[str, Any] | None = None, overrides: Mapping[str, Any] | None = None) -> Self:
        """The validated model of ``params`` (a model of this class, a mapping or None) with ``overrides`` applied."""
        if params is not None and not isinstance(params, (cls, Mapping)):
            raise TypeError(
                f"{cls.__name__}: parameters are a {cls.__name__} or a mapping, got {type(params).__name__}"
            )
        base = params.model_dump() if isinstance(params, BaseModel) else dict(params or {})
        return cls.model_validate(_overlay(cls, base, overrides or {}))

    def canonical(self) -> dict:
        """The JSON form of every parameter, defaults included (what cache keys hash and manifests record)."""
        return self.model_dump(mode="json")


def _suggesting(model: type[Params], error: dict) -> dict:
    """An error of ``model``'s validation as line-error details; a key it does not have (pydantic's extra_forbidden
    at its own level) becomes an ``unknown_parameter`` error naming the closest paths."""
    kind, loc, ctx = error["type"], error["loc"], error.get("ctx")
    if kind == "extra_forbidden" and len(loc) == 1:
        key = str(loc[0])
        close = _closest(model, key)
        fields = list(model.model_fields)
        ctx = {
            "message": _unknown_message(model.__name__, key, close, fields),
            "model": model.__name__,
            "close": close,
            "fields": fields,
        }
        kind = "unknown_parameter"
    if kind == "unknown_parameter":
        kind = PydanticCustomError("unknown_parameter", "{message}", ctx)
    elif kind not in ERROR_TYPES:  # a custom error of a validator (PydanticCustomError)
        kind = PydanticCustomError(kind, error["msg"].replace("{", "{{").replace("}", "}}"))
    return {"type": kind, "loc": loc, "input": error["input"], **({"ctx": ctx} if ctx else {})}


def _laid_over(default: Params, given: Mapping[str, Any]) -> dict[str, Any]:
    """``given`` laid over the fields ``default`` sets explicitly (the rest fall to the sub-model's own defaults)."""
    out: dict[str, Any] = {name: getattr(default, name) for name in default.model_fields_set}
    for name, value in given.items():
        inner = out.get(name)
        out[name] = _laid_over(inner, value) if isinstance(inner, Params) and isinstance(value, Mapping) else value
    return out


def _overlay(model: type[Params] | None, base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``over`` laid over ``base`` key by key, recursing into the mappings of sub-model fields."""
    out = dict(base)
    for key, value in over.items():
        field = model.model_fields.get(key) if model is not None else None
        sub = submodel(field.annotation) if field is not None else None
        inner = out.get(key)
        nest = sub is not None and isinstance(value, Mapping) and isinstance(inner, Mapping)
        out[key] = _overlay(sub, inner, value) if nest else value
    return out


def submodel(annotation) -> type[Params] | None:
    """The Params class a field holds (``X`` or ``X | None``), else None."""
    if isinstance(annotation, type) and issubclass(annotation, Params):
        return annotation
    found = [a for a in getattr(annotation, "__args__", ()) if isinstance(a, type) and issubclass(a, Params)]
    return found[0] if len(found) == 1 else None


def parameter_paths(model: type[Params], prefix: str = "") -> Iterator[str]:
    """Every parameter of ``model`` as a dotted path, each sub-model followed by its own (``loop``, ``loop.level``)."""
    for name, field in model.model_fields.items():
        yield prefix + name
        sub = submodel(field.annotation)
        if sub is not None:
            yield from parameter_paths(sub, f"{prefix}{name}.")


def _closest(model: type[Params], key: str) -> list[str]:
    """The (at most three) paths of ``model`` closest to ``key`` (difflib), matched as written, with dots read as
    underscores (so the flat ``loop_level`` of earlier versions finds ``loop.level``) and by their last name."""
    spelt: dict[str, str] = {}
    for path in parameter_paths(model):
        for form in (path, path.replace(".", "_"), path.rsplit(".", 1)[-1]):
            spelt.setdefault(form, path)
    if key in spelt:  # a flat name of earlier versions, or a parameter of a sub-model given one level too high
        return [spelt[key]]
    found = difflib.get_close_matches(key, list(spelt), n=6, cutoff=0.6)
    return list(dict.fromkeys(spelt[m] for m in found))[:3]


def _unknown_message(model: str, key: str, close: list[str], fields: list[str], prefix: str = "") -> str:
    if close:
        return f"{prefix + key}: not a parameter of {model}; did you mean {' or '.join(prefix + c for c in close)}?"
    return f"{prefix + key}: not a parameter of {model}; its parameters: {', '.join(fields)}"


def describe_error(error: Mapping[str, Any], root: str = "params") -> str:
    """One error of a parameter model's validation (an item of ``ValidationError.errors()``) as ``path: message``,
    the path dotted from ``root``; an unknown key names the closest valid parameters by their full paths."""
    loc = ".".join(str(x) for x in (root, *error["loc"]))
    if error["type"] == "unknown_parameter":
        parent = ".".join(str(x) for x in (root, *error["loc"][:-1]))
        ctx = error["ctx"]
        return _unknown_message(ctx["model"], str(error["loc"][-1]), ctx["close"], ctx["fields"], f"{parent}.")
    return f"{loc if error['loc'] else root + '.(all)'}: {error['msg'].removeprefix('Value error, ')}"


def params_model(target) -> type[Params]:
    """The parameter model a registered class or function declares (its ``Params`` attribute)."""
    model = getattr(target, "Params", None)
    if not (isinstance(model, type) and issubclass(model, Params)):
        raise TypeError(f"{getattr(target, '__qualname__', target)!r} declares no Params model")
    return model


def with_params(model: type[Params]) -> Callable:
    """Declare ``model`` as the parameters of a function whose last parameter is ``params``.

    The decorated function is called with its leading arguments and either a model instance (``params=``) or
    keywords (validated into the model); it exposes the model as ``.Params`` like a class does."""

    def decorate(func: Callable) -> Callable:
        @functools.wraps(func)
        def wrapper(*args, params: Params | Mapping[str, Any] | None = None, **overrides):
            return func(*args, params=model.of(params, overrides))

        wrapper.Params = model
        return wrapper

    return decorate


def _as_covariance(n: int):
    def check(value):
        a = np.asarray(value, dtype=float)
        if a.ndim == 0:
            a = np.full(n, float(a))
        if a.shape == (n,):
            a = np.diag(a)
        if a.shape != (n, n):
            raise ValueError(
                f"a covariance here is a scalar, {n} diagonal values or an {n}×{n} matrix, got shape {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise ValueError("a covariance must be finite")
        if not np.allclose(a, a.T, rtol=1e-9, atol=1e-12):
            raise ValueError("a covariance must be symmetric")
        if np.linalg.eigvalsh(a).min() < -1e-12 * max(1.0, float(np.abs(a).max())):
            raise ValueError("a covariance must be positive semi-definite")
        return a.tolist()

    return check


def covariance(n: int):
    """Annotated type of an n×n covariance: a scalar (n equal variances), n diagonal values or an n×n matrix;
    checked finite, symmetric and positive semi-definite, stored as the full n×n nested list."""
    return Annotated[float | list[float] | list[list[float]], AfterValidator(_as_covariance(n))]


Covariance2 = covariance(2)
Covariance3 = covariance(3)
#: a probability strictly inside (0, 1]: a χ² gate's confidence (1 disables a gate)
Probability = Annotated[float, Field(gt=0.0, le=1.0)]
