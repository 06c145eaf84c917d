"""Config keys declared once, as dataclass fields: ``setting``, ``section_of``, ``load``."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hal.options import Option, Section, is_setting, load, options_of, section_of, setting


class Mode(StrEnum):
    FAST = "fast"
    SLOW = "slow"


class Level(Enum):
    LOW = "low"
    HIGH = "high"


@dataclass(frozen=True, slots=True)
class Pid:
    """Declared kp, ki, kd."""

    kp: float = setting(0.5, "Proportional gain.", min=0, max=100, tunable=True)
    ki: float = setting(0.0, "Integral gain.", min=0, max=100)
    kd: float = setting(0.1, "Derivative gain.", min=0, max=100)


PID = section_of(Pid, "pid", "A PID controller.")


@dataclass(frozen=True, slots=True)
class BackwardsPid:
    """The same keys, declared in the opposite order."""

    kd: float = setting(0.1, "Derivative gain.", min=0, max=100)
    ki: float = setting(0.0, "Integral gain.", min=0, max=100)
    kp: float = setting(0.5, "Proportional gain.", min=0, max=100, tunable=True)


@dataclass(frozen=True, slots=True)
class Kinds:
    """One field of each type a key can have."""

    on: bool = setting(True, "A flag.")
    count: int = setting(3, "A count.", min=0)
    gain: float = setting(0.5, "A gain.")
    name: str = setting("x", "A name.")
    mode: Mode = setting(Mode.FAST, "A StrEnum.")
    level: Level = setting(Level.HIGH, "An Enum of strings.")
    names: list[str] = setting(["a"], "A list of strings.")
    numbers: tuple[float, ...] = setting((1.0, 2.0), "A tuple of numbers.")
    table: dict[str, Any] = setting({"a": 1}, "A table.")
    derived: int = 7


class TestSetting:
    def test_the_kind_comes_from_the_fields_type(self) -> None:
        """bool, int, float, str, an Enum of strings, lists or tuples of str or float, a
        dict: the Option kinds of DESIGN.md's config file."""
        kinds = {o.key: o.kind for o in options_of(Kinds)}
        assert kinds == {"on": "bool", "count": "int", "gain": "float", "name": "str",
                         "mode": "str", "level": "str", "names": "list[str]",
                         "numbers": "list[float]", "table": "table"}

    def test_the_key_is_the_fields_name_and_the_rest_is_what_setting_was_told(self) -> None:
        """kp's Option is the one a hand-written Option("kp", ...) would be."""
        assert options_of(Pid)[0] == Option("kp", "float", 0.5, "Proportional gain.", min=0,
                                            max=100, tunable=True)

    def test_an_enum_key_holds_its_value_and_offers_its_members(self) -> None:
        """The file spells the value; the dataclass holds the member."""
        by_key = {o.key: o for o in options_of(Kinds)}
        assert (by_key["mode"].default, by_key["mode"].choices) == ("fast", ("fast", "slow"))
        assert (by_key["level"].default, by_key["level"].choices) == ("high", ("low", "high"))
        values = {o.key: o.default for o in options_of(Kinds)} | {"level": "low"}
        loaded = load(Kinds, values)
        assert (loaded.mode, loaded.level) == (Mode.FAST, Level.LOW)

    def test_a_tuple_field_is_a_list_in_the_file(self) -> None:
        """The example config prints lists; the frozen dataclass keeps a tuple."""
        by_key = {o.key: o for o in options_of(Kinds)}
        assert by_key["numbers"].default == [1.0, 2.0]
        values = {o.key: o.default for o in options_of(Kinds)} | {"numbers": [3.0]}
        assert load(Kinds, values).numbers == (3.0,)

    def test_a_mutable_default_is_copied_for_each_instance(self) -> None:
        """A list or table default is a default_factory: instances share nothing."""
        one, two = Kinds(), Kinds()
        one.names.append("b")
        assert two.names == ["a"] and options_of(Kinds)[6].default == ["a"]

    def test_fields_that_are_not_keys_are_left_out(self) -> None:
        """``derived`` is a plain field: no Option, and load() takes it by name if given."""
        assert "derived" not in {o.key for o in options_of(Kinds)}
        values = {o.key: o.default for o in options_of(Kinds)}
        assert load(Kinds, values).derived == 7
        assert load(Kinds, values, derived=9).derived == 9

    def test_a_type_no_key_can_have_is_refused_naming_the_field(self) -> None:
        """A complex number is no config kind: the error names the class and the field."""

        @dataclass(frozen=True)
        class Odd:
            ratio: complex = setting(1j, "A ratio.")

        with pytest.raises(TypeError, match=r"Odd\.ratio: .* cannot be a config key"):
            options_of(Odd)

    def test_section_of_several_dataclasses_follows_their_order(self) -> None:
        """One section from two declarations: the first's keys, then the second's."""
        section = section_of((Pid, Kinds), "both", "Both.")
        assert [o.key for o in section.options] == ["kp", "ki", "kd",
                                                     *(o.key for o in options_of(Kinds))]
        assert section.configs == (Pid, Kinds)


class TestLoad:
    def test_fields_are_read_by_name_not_by_position(self) -> None:
        """A dataclass declaring kd, ki, kp reads the pid section (kp, ki, kd) right."""
        values = {o.key: o.default for o in PID.options} | {"kp": 1.0, "ki": 2.0, "kd": 3.0}
        backwards = load(BackwardsPid, values)
        assert (backwards.kp, backwards.ki, backwards.kd) == (1.0, 2.0, 3.0)
        assert load(Pid, values) == Pid(kp=1.0, ki=2.0, kd=3.0)

    @given(st.permutations(["kp", "ki", "kd"]), st.lists(
        st.floats(min_value=0, max_value=100), min_size=3, max_size=3))
    def test_the_order_of_the_values_does_not_matter(self, order: list[str],
                                                     gains: list[float]) -> None:
        """Whatever order the section's values come in, each field gets its key's value."""
        values = dict(zip(order, gains, strict=True))
        for config in (Pid, BackwardsPid):
            loaded = load(config, values)
            assert {key: getattr(loaded, key) for key in order} == values

    def test_a_missing_key_is_a_key_error_naming_it(self) -> None:
        with pytest.raises(KeyError, match="kd"):
            load(Pid, {"kp": 1.0, "ki": 0.0})


def field_default(spec: dataclasses.Field[Any]) -> Any:
    """A field's default as the file spells it (an Enum's value, a tuple as a list)."""
    if spec.default_factory is not dataclasses.MISSING:
        value = spec.default_factory()
    else:
        value = spec.default
    if isinstance(value, Enum):
        return value.value
    return list(value) if isinstance(value, tuple) else value


def declared_sections() -> list[Section]:
    from robotd.config.sections import SECTIONS

    return [s for s in SECTIONS.values() if s.configs]


class TestTheDeclaredSections:
    """Every section of the running schema that ``section_of`` built."""

    def test_some_sections_are_declared_by_their_dataclasses(self) -> None:
        assert {"line_follow", "serial", "lidar", "drive", "map", "planner", "localisation",
                "people", "viz"} <= {s.name for s in declared_sections()}

    @pytest.mark.parametrize("section", declared_sections(), ids=lambda s: s.name)
    def test_the_options_are_the_dataclass_fields(self, section: Section) -> None:
        """Same keys in the same order, each default the field's, each kind its type's."""
        fields = [f for config in section.configs for f in dataclasses.fields(config)
                  if is_setting(f)]
        assert [o.key for o in section.options] == [f.name for f in fields]
        for option, spec in zip(section.options, fields, strict=True):
            assert option.default == field_default(spec), option.key
            assert option.check(option.default) == (option.default, None), option.key
            assert option.kind == _KINDS.get(_type_name(spec), "str"), option.key

    @pytest.mark.parametrize("section", declared_sections(), ids=lambda s: s.name)
    def test_the_defaults_load_into_the_dataclasses_defaults(self, section: Section) -> None:
        """load() of the section's defaults gives what the dataclass's defaults give."""
        defaults = {o.key: o.default for o in section.options}
        for config in section.configs:
            required = {f.name: 0 for f in dataclasses.fields(config)
                        if not is_setting(f) and f.default is dataclasses.MISSING
                        and f.default_factory is dataclasses.MISSING}
            assert load(config, defaults, **required) == config(**required)

    @pytest.mark.parametrize("section", declared_sections(), ids=lambda s: s.name)
    @given(data=st.data())
    def test_any_valid_values_load_into_the_fields_of_their_names(
            self, section: Section, data: st.DataObject) -> None:
        """Values within each key's bounds, loaded: every field holds its key's value."""
        values = {o.key: data.draw(_values_of(o), label=o.key) for o in section.options}
        for config in section.configs:
            required = {f.name: 0 for f in dataclasses.fields(config)
                        if not is_setting(f) and f.default is dataclasses.MISSING
                        and f.default_factory is dataclasses.MISSING}
            loaded = load(config, values, **required)
            for spec in dataclasses.fields(config):
                if is_setting(spec):
                    held = getattr(loaded, spec.name)
                    held = held.value if isinstance(held, Enum) else held
                    held = list(held) if isinstance(held, tuple) else held
                    assert held == values[spec.name], spec.name


_KINDS = {"bool": "bool", "int": "int", "float": "float", "str": "str",
          "list[str]": "list[str]", "tuple[str, ...]": "list[str]",
          "list[float]": "list[float]", "tuple[float, ...]": "list[float]",
          "dict[str, Any]": "table", "dict[str, str]": "table", "dict[str, int]": "table"}
"""A field's annotation -> its key's kind; any other (an Enum of strings) is a str."""


def _type_name(spec: dataclasses.Field[Any]) -> str:
    return spec.type if isinstance(spec.type, str) else getattr(spec.type, "__name__", "")


def _values_of(option: Option) -> st.SearchStrategy[Any]:
    """Values an option accepts (the bounds of int and float keys, their choices)."""
    if option.choices is not None:
        return st.sampled_from(option.choices)
    low = None if option.min is None else option.min
    high = None if option.max is None else option.max
    strategies: dict[str, st.SearchStrategy[Any]] = {
        "bool": st.booleans(),
        "int": st.integers(None if low is None else int(low), None if high is None
                           else int(high)),
        "float": st.floats(low, high, allow_nan=False, allow_infinity=False),
        "str": st.text(min_size=int(low or 0), max_size=20),
        "list[str]": st.lists(st.text(max_size=5), max_size=3),
        "list[float]": st.lists(st.floats(allow_nan=False, allow_infinity=False), max_size=3),
        "table": st.dictionaries(st.text(max_size=5), st.integers(), max_size=3),
    }
    return strategies[option.kind]
