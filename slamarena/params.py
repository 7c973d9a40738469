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
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Annotated, Any, Self

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field

__all__ = ["Params", "covariance", "Covariance2", "Covariance3", "Probability", "params_model", "with_params", "Field"]


class Params(BaseModel):
    """Base of every parameter model: unknown keys are errors, defaults are validated, instances are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)

    @classmethod
    def of(cls, params: Params | Mapping[str, Any] | None = None, overrides: Mapping[str, Any] | None = None) -> Self:
        """The validated model of ``params`` (a model of this class, a mapping or None) with ``overrides`` applied."""
        if params is not None and not isinstance(params, (cls, Mapping)):
            raise TypeError(
                f"{cls.__name__}: parameters are a {cls.__name__} or a mapping, got {type(params).__name__}"
            )
        base = params.model_dump() if isinstance(params, BaseModel) else dict(params or {})
        return cls.model_validate({**base, **dict(overrides or {})})

    def canonical(self) -> dict:
        """The JSON form of every parameter, defaults included (what cache keys hash and manifests record)."""
        return self.model_dump(mode="json")


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
