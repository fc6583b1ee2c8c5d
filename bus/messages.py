"""The messages of a tick: what the world tells an agent (:class:`Sensing`, with the
:class:`Mover` s it senses), what agents tell each other (:class:`AgentState`), what an agent tells
the world (:class:`Command`), and what the world tells everyone (:class:`TickRecord`,
:class:`Event`, :class:`RobotsRecord`, :class:`PlantRecord`). Vectors and units as in
bus/types.py; docs/wire.md has their encoding.

Each field is one line: its attribute, its type and its wire form (``Wire``: its key in the
msgpack map, its default, whether it is left out when empty). Each class's ``__init__`` and the
module's ``WIRE`` are written from those lines by ``python -m shoal.bus.fields`` (bus/fields.py
says why they are written out), and bus/codec.py makes every message's encoder and decoder from
``WIRE``. A new field takes its line here (then that command), the code that gives it a value,
and its key in docs/wire.md's row; tests/bus/test_fields.py and test_wire.py fail until all
three are there.

They are made every tick, so they (and ``Memory``, ``Filtered``, ``Row`` and ``Evasion`` in
the compiled modules) are dataclasses with their own ``__init__`` and ``Final`` fields instead of
``frozen=True``: a frozen dataclass sets each field through ``object.__setattr__``, 2.4 µs for
a 7-field record made from compiled code, against 0.1 µs for a compiled ``__init__`` (0.6
interpreted). They are as immutable to mypy, and in the compiled build at run time too (a
``Final`` attribute of a compiled class is read-only); dataclasses still give them ``==``,
``hash``, ``repr``, ``fields`` and ``replace``, and :func:`picklable` pickling and copying (a
compiled class with its own ``__init__`` has no other way back).
"""

from __future__ import annotations

import copyreg
from dataclasses import dataclass, fields
from typing import Annotated, Any, Final

from shoal.bus.fields import Wire
from shoal.bus.types import Vector


@dataclass(init=False, slots=True, unsafe_hash=True)
class Mover:
    """A moving obstacle (a person, a cart) as an agent senses it at the start of a tick.

    obstacle_id : its index in the scenario's obstacles; centre (m) and velocity (m/s) at the
    start of the tick, the velocity it holds over the tick (the world reports the truth; a real
    sensor's estimate would carry its error, docs/people.md); radius, m; speed_cap u_max, m/s:
    the fastest it can move, which the safety filter's row assumes, whatever its velocity.
    """

    obstacle_id: Final[int]
    centre: Final[Vector]
    radius: Final[float]
    velocity: Final[Vector]
    speed_cap: Final[float]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, obstacle_id: int, centre: Vector, radius: float, velocity: Vector,
                       speed_cap: float) -> None:  # fmt: skip
        self.obstacle_id, self.centre, self.radius = obstacle_id, centre, radius
        self.velocity, self.speed_cap = velocity, speed_cap

    # End of what is written.


@dataclass(init=False, slots=True, unsafe_hash=True)
class Sensing:
    """World → agent at the start of tick ``tick``: where the agent is and what it senses.

    obstacle_centres : (m, dim) metres; obstacle_radii : (m,) metres, in obstacle-id order: the
        standing obstacles, which the nominal law (Algorithm 2, the leader's detour) plans round.
    agent_ids, agent_positions : the other agents within the sensing radius and where they are
        at the start of this same tick, (q, dim) metres, in id order (the safety filter's rows).
    movers : the moving obstacles within the sensing radius, in obstacle-id order; only the
        safety filter acts on them (docs/people.md).
    heading : rad, a unicycle's heading at the start of the tick (0 for a single integrator):
        the safety filter meets its limits as rows for it (docs/safety.md, Unicycles).
    """

    tick: Final[Annotated[int, Wire("tick")]]
    position: Final[Annotated[Vector, Wire("pos")]]
    obstacle_ids: Final[Annotated[tuple[int, ...], Wire("oid")]]
    obstacle_centres: Final[Annotated[tuple[Vector, ...], Wire("oc")]]
    obstacle_radii: Final[Annotated[tuple[float, ...], Wire("or")]]
    agent_ids: Final[Annotated[tuple[int, ...], Wire("aid", default=())]]
    agent_positions: Final[Annotated[tuple[Vector, ...], Wire("ap", default=())]]
    movers: Final[Annotated[tuple[Mover, ...], Wire("mv", default=(), sparse=True)]]
    heading: Final[Annotated[float, Wire("hd", default=0.0, sparse=True)]]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, tick: int, position: Vector, obstacle_ids: tuple[int, ...],
                       obstacle_centres: tuple[Vector, ...], obstacle_radii: tuple[float, ...],
                       agent_ids: tuple[int, ...] = (), agent_positions: tuple[Vector, ...] = (),
                       movers: tuple[Mover, ...] = (), heading: float = 0.0) -> None:  # fmt: skip
        self.tick, self.position, self.obstacle_ids = tick, position, obstacle_ids
        self.obstacle_centres, self.obstacle_radii = obstacle_centres, obstacle_radii
        self.agent_ids, self.agent_positions, self.movers = agent_ids, agent_positions, movers
        self.heading = heading

    # End of what is written.


@dataclass(init=False, slots=True, unsafe_hash=True)
class AgentState:
    """Agent → its neighbours at tick ``tick``: position (m), collision-course flag Ω_i, the
    current value of its σ bid in Algorithm 1, and the scale σ and rotation θ (rad) it applies.
    """

    agent_id: Final[Annotated[int, Wire("id")]]
    tick: Final[Annotated[int, Wire("tick")]]
    position: Final[Annotated[Vector, Wire("pos")]]
    omega: Final[Annotated[bool, Wire("omega")]]
    bid: Final[Annotated[float, Wire("bid")]]
    sigma: Final[Annotated[float, Wire("sigma")]]
    theta: Final[Annotated[float, Wire("theta")]]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, agent_id: int, tick: int, position: Vector, omega: bool, bid: float,
                       sigma: float, theta: float) -> None:  # fmt: skip
        self.agent_id, self.tick, self.position, self.omega = agent_id, tick, position, omega
        self.bid, self.sigma, self.theta = bid, sigma, theta

    # End of what is written.


@dataclass(init=False, slots=True, unsafe_hash=True)
class Command:
    """Agent → world: the velocity v_i (m/s) to hold during tick ``tick``; ``filtered``: the
    agent's safety filter changed its nominal velocity to get it."""

    agent_id: Final[Annotated[int, Wire("id")]]
    tick: Final[Annotated[int, Wire("tick")]]
    velocity: Final[Annotated[Vector, Wire("vel")]]
    filtered: Final[Annotated[bool, Wire("flt", default=False)]]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, agent_id: int, tick: int, velocity: Vector,
                       filtered: bool = False) -> None:  # fmt: skip
        self.agent_id, self.tick, self.velocity, self.filtered = agent_id, tick, velocity, filtered

    # End of what is written.


@dataclass(init=False, slots=True, unsafe_hash=True)
class TickRecord:
    """World → all, once per tick: the ground truth of tick ``tick``.

    positions (n, dim) m at the start of the tick and velocities (n, dim) m/s held during it, as
    nested tuples in agent-id order; omega, bid, sigma, theta as each agent announced them; alive
    False for an agent the world holds still because its process is gone; filtered True where
    the agent's safety filter changed its nominal velocity that tick. mover_centres (m) and
    mover_velocities (m/s): every moving obstacle at the start of the tick and over it, in
    obstacle order (empty when none moves). headings (rad): every unicycle's heading at the
    start of the tick, agent-id order (empty for single integrators).
    """

    tick: Final[Annotated[int, Wire("tick")]]
    positions: Final[Annotated[tuple[Vector, ...], Wire("pos")]]
    velocities: Final[Annotated[tuple[Vector, ...], Wire("vel")]]
    omega: Final[Annotated[tuple[bool, ...], Wire("omega")]]
    bid: Final[Annotated[tuple[float, ...], Wire("bid")]]
    sigma: Final[Annotated[tuple[float, ...], Wire("sigma")]]
    theta: Final[Annotated[tuple[float, ...], Wire("theta")]]
    alive: Final[Annotated[tuple[bool, ...], Wire("alive")]]
    filtered: Final[Annotated[tuple[bool, ...], Wire("flt")]]
    mover_centres: Final[Annotated[tuple[Vector, ...], Wire("mc", default=(), sparse=True)]]
    mover_velocities: Final[Annotated[tuple[Vector, ...], Wire("mw", default=(), sparse=True)]]
    headings: Final[Annotated[tuple[float, ...], Wire("hd", default=(), sparse=True)]]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, tick: int, positions: tuple[Vector, ...], velocities: tuple[Vector, ...],
                       omega: tuple[bool, ...], bid: tuple[float, ...], sigma: tuple[float, ...],
                       theta: tuple[float, ...], alive: tuple[bool, ...],
                       filtered: tuple[bool, ...], mover_centres: tuple[Vector, ...] = (),
                       mover_velocities: tuple[Vector, ...] = (),
                       headings: tuple[float, ...] = ()) -> None:  # fmt: skip
        self.tick, self.positions, self.velocities, self.omega = tick, positions, velocities, omega
        self.bid, self.sigma, self.theta, self.alive = bid, sigma, theta, alive
        self.filtered, self.mover_centres = filtered, mover_centres
        self.mover_velocities, self.headings = mover_velocities, headings

    # End of what is written.


@dataclass(init=False, slots=True, unsafe_hash=True)
class Event:
    """World → all: a line for the log. level: 1 debug, 2 info, 3 warning, 4 error (as
    foxglove.Log); agent: the agent it is about, 0 if none."""

    tick: Final[Annotated[int, Wire("tick")]]
    level: Final[Annotated[int, Wire("level")]]
    agent: Final[Annotated[int, Wire("agent")]]
    text: Final[Annotated[str, Wire("text")]]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, tick: int, level: int, agent: int, text: str) -> None:  # fmt: skip
        self.tick, self.level, self.agent, self.text = tick, level, agent, text

    # End of what is written.


@dataclass(init=False, slots=True, unsafe_hash=True)
class RobotsRecord:
    """World → all, each tick of a run that drives robots (issue 33): what the robots were sent
    and what they reported. twists: the command each robot was sent for the tick, (linear x,
    linear y, angular z) in m/s and rad/s in its own frame (a unicycle's linear y is 0); ages
    (s): how old each robot's pose was when the world read it at the tick's start (empty when
    the robots cannot tell). Agent-id order."""

    tick: Final[Annotated[int, Wire("tick")]]
    twists: Final[Annotated[tuple[Vector, ...], Wire("twist")]]
    ages: Final[Annotated[tuple[float, ...], Wire("age", default=(), sparse=True)]]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, tick: int, twists: tuple[Vector, ...],
                       ages: tuple[float, ...] = ()) -> None:  # fmt: skip
        self.tick, self.twists, self.ages = tick, twists, ages

    # End of what is written.


@dataclass(init=False, slots=True, unsafe_hash=True)
class PlantRecord:
    """World → all, each tick of a run on a physics plant (``--plant mujoco``, docs/physics.md):
    the robots as the engine moved them, at the tick's end. bodies: each robot's body (m; a
    wheeled robot's axle midpoint, a base's centre) and yaws (rad; empty in 3-D); velocities:
    each body's (m/s) and turn_rates its yaw rate (rad/s; empty in 3-D); motor_speeds: each
    motor's joint speed (a wheel's rad/s, a base's slide m/s) and motor_efforts what it applied
    at the tick's last physics step (N·m, N), in the model's motor order (each robot's in agent
    order: a wheeled robot's left then right, a base's x, y[, z]); contacts: every contact the
    engine reported during the tick as (agent id, what it touched, depth m < 0), what it touched
    an agent id 1..n or n + 1 + k for obstacle k (scenario order). Agent-id order."""

    tick: Final[Annotated[int, Wire("tick")]]
    bodies: Final[Annotated[tuple[Vector, ...], Wire("body")]]
    velocities: Final[Annotated[tuple[Vector, ...], Wire("vel")]]
    motor_speeds: Final[Annotated[tuple[float, ...], Wire("speed")]]
    motor_efforts: Final[Annotated[tuple[float, ...], Wire("effort")]]
    yaws: Final[Annotated[tuple[float, ...], Wire("yaw", default=(), sparse=True)]]
    turn_rates: Final[Annotated[tuple[float, ...], Wire("turn", default=(), sparse=True)]]
    contacts: Final[Annotated[tuple[Vector, ...], Wire("contact", default=(), sparse=True)]]

    # Written by `python -m shoal.bus.fields` from the fields above; not by hand.
    def __init__(self, tick: int, bodies: tuple[Vector, ...], velocities: tuple[Vector, ...],
                       motor_speeds: tuple[float, ...], motor_efforts: tuple[float, ...],
                       yaws: tuple[float, ...] = (), turn_rates: tuple[float, ...] = (),
                       contacts: tuple[Vector, ...] = ()) -> None:  # fmt: skip
        self.tick, self.bodies, self.velocities = tick, bodies, velocities
        self.motor_speeds, self.motor_efforts, self.yaws = motor_speeds, motor_efforts, yaws
        self.turn_rates, self.contacts = turn_rates, contacts

    # End of what is written.


def _rebuilt(record: Any) -> tuple[type[Any], tuple[Any, ...]]:
    return type(record), tuple([getattr(record, f.name) for f in fields(record)])


def picklable(*classes: type[Any]) -> None:
    """Pickle and copy instances of these dataclasses as their class called on their fields'
    values, in either build (a compiled class with its own ``__init__`` cannot be rebuilt the
    default way: pickle calls it with no arguments)."""
    for cls in classes:
        copyreg.pickle(cls, _rebuilt)


picklable(Mover, Sensing, AgentState, Command, TickRecord, Event, RobotsRecord, PlantRecord)

# Written by `python -m shoal.bus.fields` from the fields above; not by hand.
WIRE: dict[type[Any], tuple[str, ...]] = {
    Sensing: ("tick:int", "pos:vector", "oid:ints", "oc:vectors", "or:floats", "aid:ints",
              "ap:vectors", "mv:movers?", "hd:float?"),
    AgentState: ("id:int", "tick:int", "pos:vector", "omega:bool", "bid:float", "sigma:float",
                 "theta:float"),
    Command: ("id:int", "tick:int", "vel:vector", "flt:bool"),
    TickRecord: ("tick:int", "pos:vectors", "vel:vectors", "omega:bools", "bid:floats",
                 "sigma:floats", "theta:floats", "alive:bools", "flt:bools", "mc:vectors?",
                 "mw:vectors?", "hd:floats?"),
    Event: ("tick:int", "level:int", "agent:int", "text:str"),
    RobotsRecord: ("tick:int", "twist:vectors", "age:floats?"),
    PlantRecord: ("tick:int", "body:vectors", "vel:vectors", "speed:floats", "effort:floats",
                  "yaw:floats?", "turn:floats?", "contact:vectors?"),
}  # fmt: skip
# End of what is written.
