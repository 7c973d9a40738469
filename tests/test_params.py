"""The parameter base (slamarena.params): sub-models laid over the owner's defaults, unknown keys with the closest
valid paths, every error reported at its path."""

from __future__ import annotations

import pytest
from pydantic import ValidationError, field_validator

from slamarena.params import Field, Params, describe_error, parameter_paths


class Inner(Params):
    level: int = Field(0, ge=0, description="a level")
    width: float = Field(1.0, description="a width [m]")
    name: str = Field("a", description="a name")

    @field_validator("name")
    @classmethod
    def _lower(cls, value: str) -> str:
        if value != value.lower():
            raise ValueError("lower case only")
        return value


class Outer(Params):
    count: int = Field(1, description="a count")
    loop: Inner = Field(Inner(level=2), description="a section whose default differs from Inner's own")
    other: Inner | None = Field(None, description="an optional section")


def test_a_section_given_in_part_keeps_the_owners_defaults_in_it():
    assert Outer(loop={"width": 3.0}).loop == Inner(level=2, width=3.0)
    assert Outer(loop=Inner(width=3.0)).loop == Inner(width=3.0)  # a model instance is taken as it is
    assert Outer(other={"width": 3.0}).other == Inner(width=3.0)  # no owner's default: the sub-model's own
    # overrides laid over a given model, key by key inside a section
    assert Outer.of(Outer(loop={"width": 3.0}), {"loop": {"name": "b"}}).loop == Inner(level=2, width=3.0, name="b")


def test_an_unknown_key_names_the_closest_paths_and_every_other_error_is_kept():
    with pytest.raises(ValidationError) as err:
        Outer(cont=2, loop={"levle": 1, "name": "B"}, loop_width=2.0, zzz=1)
    described = {describe_error(e) for e in err.value.errors()}
    assert described == {
        "params.cont: not a parameter of Outer; did you mean params.count?",
        "params.loop.levle: not a parameter of Inner; did you mean params.loop.level?",
        "params.loop.name: lower case only",
        "params.loop_width: not a parameter of Outer; did you mean params.loop.width?",
        "params.zzz: not a parameter of Outer; its parameters: count, loop, other",
    }
    assert {e["loc"] for e in err.value.errors() if e["type"] == "unknown_parameter"} == {
        ("cont",),
        ("loop", "levle"),
        ("loop_width",),
        ("zzz",),
    }


def test_errors_without_an_unknown_key_are_pydantics_own():
    with pytest.raises(ValidationError) as err:
        Outer(loop={"level": -1})
    assert [(e["type"], e["loc"]) for e in err.value.errors()] == [("greater_than_equal", ("loop", "level"))]


def test_parameter_paths_expand_sub_models():
    assert list(parameter_paths(Outer)) == [
        "count",
        "loop",
        "loop.level",
        "loop.width",
        "loop.name",
        "other",
        "other.level",
        "other.width",
        "other.name",
    ]
