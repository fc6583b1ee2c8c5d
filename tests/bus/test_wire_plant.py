"""The ``plant`` record on the wire (a physics run's bodies, motors and contacts per tick):
every field round-trips bit for bit, what a 3-D or contact-free run lacks is left out, and a
record whose per-robot or per-motor fields disagree is refused, naming the kind."""

from __future__ import annotations

import pytest

from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.bus.messages import PlantRecord

TWO = PlantRecord(
    12,
    bodies=((0.5, -0.25), (1.0, 2.0)),
    velocities=((0.1, 0.0), (0.0, -0.3)),
    motor_speeds=(6.25, 6.0, 0.0, -0.3),
    motor_efforts=(0.01, -0.004, 0.0, -1.5),
    yaws=(0.1, -3.0),
    turn_rates=(0.0, 0.2),
    contacts=((1.0, 4.0, -0.0021),),
)


def test_a_plant_record_round_trips_bit_for_bit() -> None:
    data = codec.encode_plant(TWO)
    assert codec.decode_plant(data) == TWO
    assert codec.decode(PlantRecord, data) == TWO


def test_what_a_3d_run_without_contacts_lacks_is_left_out() -> None:
    space = PlantRecord(3, bodies=((0.0, 1.0, 2.0),), velocities=((0.0, 0.0, 0.5),),
                        motor_speeds=(0.0, 0.0, 0.5), motor_efforts=(0.0, 0.0, 1.0))  # fmt: skip
    data = codec.encode_plant(space)
    for key in (b"yaw", b"turn", b"contact"):
        assert key not in data
    assert codec.decode_plant(data) == space


@pytest.mark.parametrize(
    "changes",
    [
        {"velocities": ((0.1, 0.0),)},  # one robot's velocity missing
        {"yaws": (0.1,)},
        {"motor_efforts": (0.0,)},
        {"bodies": ((0.5, -0.25, 1.0), (1.0, 2.0))},  # a 3-D body among 2-D ones
        {"contacts": ((1.0, 4.0),)},
    ],
)
def test_a_record_whose_fields_disagree_is_refused(changes: dict[str, object]) -> None:
    names = ("bodies", "velocities", "motor_speeds", "motor_efforts", "yaws", "turn_rates",
             "contacts")  # fmt: skip
    fields = {f: getattr(TWO, f) for f in names}
    bad = PlantRecord(12, **{**fields, **changes})  # type: ignore[arg-type]
    with pytest.raises(DecodeError, match="plant"):
        codec.decode_plant(codec.encode_plant(bad))
