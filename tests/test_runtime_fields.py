"""Variables read from decoded messages (rmvdsl.runtime.fields): real rosbags
message objects built from the CARLA bridge's definitions, and JSON mappings,
against values worked out by hand."""

from __future__ import annotations

from fractions import Fraction

import pytest
from conftest import EXAMPLES, ROOT
from hypothesis import given, settings
from hypothesis import strategies as st

from rmvdsl.check import check
from rmvdsl.ir import lower
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.fields import MISSING, FieldError, aggregate, read


@pytest.fixture(scope="module")
def carla():
    """The resolved abs.rmv and a rosbags type store with the CARLA messages."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    types = {}
    for path in sorted((EXAMPLES / "carla" / "msg").rglob("*.msg")):
        name = f"{path.parent.parent.name}/msg/{path.stem}"
        types.update(get_types_from_msg(path.read_text(encoding="utf-8"), name))
    store.register(types)
    spec = lower(check(str(ROOT / "examples" / "carla" / "abs.rmv")))
    return spec, store


def _variable(spec: ir.Spec, name: str) -> ir.Variable:
    return next(v for v in spec.variables if v.name == name)


def _status(store, velocity: float, brake: float, hand_brake: bool):
    types = store.types
    time = types["builtin_interfaces/msg/Time"](sec=12, nanosec=500_000_000)
    header = types["std_msgs/msg/Header"](seq=1, stamp=time, frame_id="hero")
    vector = types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    accel = types["geometry_msgs/msg/Accel"](linear=vector, angular=vector)
    quaternion = types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    control = types["carla_msgs/msg/CarlaEgoVehicleControl"](
        header=header, throttle=0.25, steer=0.0, brake=brake, hand_brake=hand_brake,
        reverse=False, gear=1, manual_gear_shift=False,
    )  # fmt: skip
    return types["carla_msgs/msg/CarlaEgoVehicleStatus"](
        header=header, velocity=velocity, acceleration=accel, orientation=quaternion,
        control=control,
    )  # fmt: skip


def test_scalar_fields_of_a_rosbags_message(carla):
    spec, store = carla
    message = _status(store, velocity=13.5, brake=0.9, hand_brake=True)
    assert read(_variable(spec, "Velocity"), message) == 13.5
    assert read(_variable(spec, "BrakePedal"), message) == pytest.approx(0.9)
    assert read(_variable(spec, "HandBrake"), message) is True
    assert read(_variable(spec, "GasPedal"), message) == 0.25


def _objects(store, speeds: list[float]):
    types = store.types
    time = types["builtin_interfaces/msg/Time"](sec=0, nanosec=0)
    header = types["std_msgs/msg/Header"](seq=0, stamp=time, frame_id="map")
    objects = []
    for number, speed in enumerate(speeds):
        linear = types["geometry_msgs/msg/Vector3"](x=speed, y=0.0, z=0.0)
        twist = types["geometry_msgs/msg/Twist"](linear=linear, angular=linear)
        objects.append({"id": number, "twist": twist})
    return {"header": header, "objects": objects}


def test_an_aggregate_over_every_element(carla):
    spec, store = carla
    fastest = _variable(spec, "FastestObject")  # max(objects.objects[*].twist.linear.x)
    assert read(fastest, _objects(store, [3.0, 31.5, -40.0])) == 31.5
    assert read(fastest, _objects(store, [])) is MISSING  # no object: no sample


def _variable_at(path: list[ir.Step], kind: str, aggregate_name: str | None = None):
    return ir.Variable("V", "t", tuple(path), aggregate_name, ir.ValueType(kind), "", "")


def test_json_messages_indices_and_times():
    stamp = [ir.FieldStep("header", "header", "std_msgs/msg/Header"),
             ir.FieldStep("stamp", "stamp", "time")]  # fmt: skip
    message = {"header": {"stamp": {"sec": 3, "nanosec": 250_000_000}}, "ranges": [1.5, 2.5]}
    assert read(_variable_at(stamp, "time"), message) == Fraction(13, 4)
    secs = [*stamp, ir.FieldStep("secs", "sec", "uint32")]
    assert read(_variable_at(secs, "int"), message) == 3  # ROS 1's `secs` read as `sec`
    ranges = ir.FieldStep("ranges", "ranges", "float32[]")
    assert read(_variable_at([ranges, ir.IndexStep(1)], "float"), message) == 2.5
    assert read(_variable_at([ranges, ir.IndexStep(5)], "float"), message) is MISSING
    with pytest.raises(FieldError, match="no field `range`"):
        read(_variable_at([ir.FieldStep("range", "range", "float32")], "float"), message)
    with pytest.raises(FieldError, match="expected an array"):
        read(_variable_at([stamp[0], ir.EachStep()], "int", "count"), message)


@pytest.mark.parametrize(
    ("name", "values", "expected"),
    [
        ("count", [], 0),
        ("count", [4, 5], 2),
        ("sum", [], 0),
        ("sum", [1, 2, 3], 6),
        ("min", [], MISSING),
        ("max", [2, 9, 4], 9),
        ("mean", [1, 2], 1.5),
        ("mean", [], MISSING),
        ("any", [], False),
        ("any", [False, True], True),
        ("all", [], True),
        ("all", [True, False], False),
        ("number", [True], 1),
        ("number", [False], 0),
    ],
)
def test_array_aggregates(name, values, expected):
    assert (
        aggregate(name, values) == expected
        if expected is not MISSING
        else (aggregate(name, values) is MISSING)
    )


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    ("name", "values", "expected"),
    [
        ("min", [NAN, 0.1, 5.0], 0.1),  # a driver's missed return first ...
        ("min", [5.0, 0.1, NAN], 0.1),  # ... or last: the same minimum
        ("max", [NAN, NAN], MISSING),  # no reading at all
        ("mean", [NAN, 1.0, 2.0], 1.5),
        ("sum", [NAN, 1.0], 1.0),
        ("sum", [INF, -INF], NAN),
        ("count", [NAN, 1.0], 2),  # the elements, as written
        ("sum", [2**63 - 1, 1], -(2**63)),  # int64, as the runtime holds integers
        ("mean", [2**63 - 1, 2**63 - 1], float(2**63 - 1)),  # exact, no wrap
    ],
)
def test_nan_is_no_reading(name, values, expected):
    found = aggregate(name, values)
    if expected is MISSING:
        assert found is MISSING
    elif expected != expected:
        assert found != found
    else:
        assert found == expected and type(found) is type(expected)


@settings(max_examples=500, deadline=None)
@given(
    st.sampled_from(["min", "max", "sum", "mean", "count", "any", "all"]),
    st.lists(st.one_of(st.floats(), st.sampled_from([0.0, -0.0, NAN, INF, -INF])), max_size=8),
    st.randoms(use_true_random=False),
)
def test_no_array_aggregate_depends_on_element_order(name, values, random):
    shuffled = list(values)
    random.shuffle(shuffled)
    assert repr(aggregate(name, values)) == repr(aggregate(name, shuffled))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(-(2**64), 2**64), max_size=6), st.randoms(use_true_random=False))
def test_integer_aggregates_do_not_depend_on_element_order(values, random):
    shuffled = list(values)
    random.shuffle(shuffled)
    for name in ("min", "max", "sum", "mean"):
        assert repr(aggregate(name, values)) == repr(aggregate(name, shuffled))


@settings(max_examples=500, deadline=None)
@given(
    st.lists(
        st.one_of(st.floats(allow_nan=False), st.integers(-3, 3), st.sampled_from([0, 0.0, -0.0])),
        min_size=1,
        max_size=8,
    )
)
def test_min_and_max_are_those_of_numbers_ordered_with_minus_zero_first(values):
    """`min` and `max` of an array take plain `min` and `max`, and order the zeros
    only where the result is zero: the same element, of the same type and sign, as
    ordering every element by (value, sign) gives."""
    from rmvdsl.runtime.fields import _order

    for name, pick in (("min", min), ("max", max)):
        expected = pick(values, key=_order)
        found = aggregate(name, values)
        assert repr(found) == repr(expected) and type(found) is type(expected)


def test_a_uint64_above_int64_wraps_as_the_docs_say():
    """InfluxDB's integers are int64: the runtime holds 2^64 - 1 as -1, as the
    solver's 64-bit bit-vectors do (`not (U = 18446744073709551615)` never fails)."""
    variable = ir.Variable(
        "U", "/u", (ir.FieldStep("data", "data", "uint64"),), None,
        ir.ValueType("int", "uint64"), "", "",
    )  # fmt: skip
    assert read(variable, {"data": 2**64 - 1}) == -1
    assert read(variable, {"data": 2**63}) == -(2**63)
    assert read(variable, {"data": 7}) == 7


class _Node:
    """A decoded message's object: attributes only."""

    def __init__(self, **fields: object) -> None:
        self.__dict__.update(fields)


_LEAVES = st.one_of(
    st.booleans(), st.integers(-(2**70), 2**70), st.floats(allow_nan=True),
    st.sampled_from([float("nan"), "text", None]),
)  # fmt: skip


@st.composite
def _aggregated(draw):
    """A message with `a[*].b` (or `a[*].b[*]`), its elements objects, mappings,
    lists, tuples or numpy arrays, holding values of every kind, and a variable of
    every array aggregate over it."""
    import numpy

    inner_each = draw(st.booleans())
    leaf_type = draw(st.sampled_from(["float64", "int32", "bool"]))

    def leaf():
        if inner_each:
            items = draw(st.lists(_LEAVES, max_size=3))
            shape = draw(st.sampled_from(["list", "tuple", "numpy"]))
            if shape == "numpy" and all(type(v) in (int, float) for v in items):
                return numpy.array(items, dtype=float)
            return tuple(items) if shape == "tuple" else items
        return draw(_LEAVES)

    def element():
        value = leaf()
        return {"b": value} if draw(st.integers(0, 9)) == 0 else _Node(b=value)

    elements = [element() for _ in range(draw(st.integers(0, 4)))]
    container = tuple(elements) if draw(st.booleans()) else elements
    message = {"a": container} if draw(st.integers(0, 9)) == 0 else _Node(a=container)
    path = [ir.FieldStep("a", "a", "pkg/msg/E[]"), ir.EachStep(),
            ir.FieldStep("b", "b", f"{leaf_type}[]" if inner_each else leaf_type)]  # fmt: skip
    if inner_each:
        path.append(ir.EachStep())
    name = draw(st.sampled_from(["min", "max", "sum", "mean", "count", "any", "all"]))
    kind = "int" if name == "count" else "bool" if name in ("any", "all") else "float"
    return _variable_at(path, kind, name), message


def _outcome(read_it, message):
    try:
        value = read_it(message)
    except (FieldError, IndexError) as error:
        return type(error).__name__
    return type(value).__name__, "nan" if isinstance(value, float) and value != value else value


@settings(max_examples=400, deadline=None)
@given(_aggregated())
def test_an_aggregate_s_fast_reader_reads_what_read_reads(case):
    """fields.reader's fast path for aggregates over attribute objects gives what
    `read` gives on any message: mappings, numpy arrays, values of another type."""
    from rmvdsl.runtime.fields import reader

    variable, message = case
    fast = reader(variable)
    assert _outcome(fast, message) == _outcome(lambda m: read(variable, m), message)
