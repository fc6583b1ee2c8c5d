"""The processes of a run, each described once: a frozen dataclass per command (``shoal router``,
``logger``, ``world``, ``agent``) whose fields carry their click declarations.

The command declares its options from it (:func:`click_options`) and builds it back from what
click parsed (:meth:`ChildSpec.of`); ``shoal run``'s launcher gives a child its command line
(:meth:`ChildSpec.argv`) and the compose file its environment (:meth:`ChildSpec.environment`),
so the spellings cannot drift apart (tests/tools/test_children.py parses every command line back).
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Callable, Mapping
from dataclasses import MISSING, dataclass, field, fields
from functools import partial
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import click

from shoal.bus.errors import WireError
from shoal.bus.keys import Keys
from shoal.bus.types import Clock, SafetyLayer
from shoal.world.dynamics import PRESETS
from shoal.world.loader import ROS_DISTROS, ROS_POSES
from shoal.world.plant import KINEMATICS, PLANTS

F = TypeVar("F", bound=Callable[..., Any])
_ENUMS: dict[str, type[enum.Enum]] = {  # fields' choices (None where the default is)
    "Clock": Clock,
    "SafetyLayer | None": SafetyLayer,
}
S = TypeVar("S", bound="ChildSpec")


def check_run_id(_ctx: click.Context, _param: click.Parameter, value: str | None) -> str | None:
    """Refuse a run id that cannot be a Zenoh key chunk, before anything starts."""
    if value is not None:
        try:
            Keys(value)
        except WireError as exc:
            raise click.BadParameter(str(exc)) from None
    return value


def option(*decls: str, default: Any = MISSING, identity: bool = False, **click_kwargs: Any) -> Any:
    """A child's option: ``decls`` as click takes them (the first is the flag a command line
    gives), the field's default (none: the option is required) and click's other settings.
    ``identity``: it says which process this is (an agent's id), so a compose service keeps it
    on its command line rather than in its environment."""
    metadata = {"decls": decls, "click": click_kwargs, "identity": identity}
    return field(default=default, metadata=metadata)


def argument(*, default: Any = MISSING, **click_kwargs: Any) -> Any:
    """A child's positional argument."""
    return field(default=default, metadata={"argument": True, "click": click_kwargs})


@dataclass(frozen=True, kw_only=True)
class ChildSpec:
    """What one child process is started with. ``command``: its ``shoal`` subcommand."""

    command: ClassVar[str]

    @classmethod
    def of(cls: type[S], params: Mapping[str, Any]) -> S:
        """The spec from a command's parsed parameters (others in ``params`` are ignored)."""
        values = {}
        for f in fields(cls):
            value = params[f.name]
            if f.type in _ENUMS and value is not None:
                value = _ENUMS[f.type](value)
            values[f.name] = tuple(value) if isinstance(value, list) else value
        return cls(**values)

    def _given(self) -> list[tuple[dataclasses.Field[Any], Any]]:
        """The arguments, and the options whose value is not their default, with the values."""
        return [
            (f, getattr(self, f.name))
            for f in fields(self)
            if f.metadata.get("argument")
            or f.default is MISSING
            or getattr(self, f.name) != f.default
        ]

    def argv(self) -> list[str]:
        """``shoal`` arguments that start this child: the subcommand, then every argument and
        every option that differs from its default."""
        return [self.command, *self._arguments(lambda _f: True)]

    def identity(self) -> list[str]:
        """The arguments and the options that say which process this is (a compose service's
        command after the subcommand; the rest goes in :meth:`environment`)."""
        return self._arguments(lambda f: bool(f.metadata.get("identity")))

    def _arguments(self, options: Callable[[dataclasses.Field[Any]], bool]) -> list[str]:
        out = [_text(v) for f, v in self._given() if f.metadata.get("argument")]
        for f, value in self._given():
            if f.metadata.get("argument") or not options(f):
                continue
            flag = f.metadata["decls"][0]
            if isinstance(value, bool):
                out += [flag] if value else []
            elif isinstance(value, tuple):
                for item in value:
                    out += [flag, _text(item)]
            elif value is not None:
                out += [flag, _text(value)]
        return out

    def environment(self) -> dict[str, str]:
        """Every option that differs from its default as the environment variable click reads
        for it (``SHOAL_<COMMAND>_<NAME>``; a repeated option's values space-separated)."""
        prefix = f"SHOAL_{self.command.upper()}_"
        env = {}
        for f, value in self._given():
            if f.metadata.get("argument") or f.metadata.get("identity") or value is None:
                continue
            if isinstance(value, tuple):
                text = " ".join(_text(v) for v in value)
            elif isinstance(value, bool):
                text = "1" if value else "0"
            else:
                text = _text(value)
            env[f.metadata["click"].get("envvar", prefix + f.name.upper())] = text
        return env


def _text(value: Any) -> str:
    if isinstance(value, enum.Enum):
        return str(value.value)
    return repr(value) if isinstance(value, float) else str(value)


def click_options(spec: type[ChildSpec], only: tuple[str, ...] = ()) -> Callable[[F], F]:
    """Declare ``spec``'s fields (``only`` these, if given) as a command's click arguments and
    options, in field order (click shows them in declaration order)."""

    def add(func: F) -> F:
        for f in reversed(fields(spec)):
            if only and f.name not in only:
                continue
            kwargs = dict(f.metadata["click"])
            if f.metadata.get("argument"):
                if f.default is not MISSING:
                    kwargs.setdefault("default", f.default)
                func = click.argument(f.name, **kwargs)(func)
                continue
            if f.default is MISSING:
                kwargs.setdefault("required", True)
            elif f.default is not None:
                default = f.default
                kwargs.setdefault("default", str(default) if f.type in _ENUMS else default)
            func = click.option(*f.metadata["decls"], f.name, **kwargs)(func)
        return func

    return add


_SECURE = click.Path(exists=True, file_okay=False, path_type=Path)
_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)
_MS = click.FloatRange(min=0.0, max=10_000.0)
_RATE = click.FloatRange(min=0.0, max=1.0, max_open=True)
_DOMAIN = click.IntRange(0, 232)  # ROS_DOMAIN_ID
_DISTRO = click.Choice(list(ROS_DISTROS))

# The options several processes take, each declared once here with its flag, its type and its
# default; a process's own field adds only its help (what the option means to that process).
_connect = partial(option, "--connect", "-e", default=(), multiple=True)
_listen = partial(option, "--listen", "-l", default=(), multiple=True)
_zenoh_config = partial(option, "--zenoh-config", default=None, type=_FILE)
_secure = partial(
    option, "--secure", default=None, type=_SECURE,
    help="Secured mode: TLS with mutual authentication, passwords and the run's access rules, "
    "from DIR (made by `shoal certs DIR`; docs/security.md).",
)  # fmt: skip
_start_timeout = partial(option, "--start-timeout", default=60.0)
_jitter_ms = partial(option, "--jitter-ms", default=0.0, type=_MS)
_ros_connect = partial(option, "--ros-connect", default=(), multiple=True)
_ros_namespaces = partial(option, "--ros-namespace", default=(), multiple=True)
_FROM_SCENARIO = "[default: the scenario's robots: section, else {}]"


@dataclass(frozen=True, kw_only=True)
class ClientSpec(ChildSpec):
    """The options of a process that joins a run as a client of its router."""

    run_id: str = option("--run", callback=check_run_id, help="The run id every key lives under.")
    connect: tuple[str, ...] = _connect(
        help="Zenoh endpoint of the router, e.g. tcp/127.0.0.1:7447 (repeatable)."
    )
    zenoh_config: Path | None = _zenoh_config(
        help="A Zenoh JSON5 config file (ZENOH_CONFIG is honoured too)."
    )
    multicast: bool = option(
        "--multicast", default=False, is_flag=True,
        help="Allow Zenoh multicast scouting (off by default).",
    )  # fmt: skip
    secure: Path | None = _secure()


@dataclass(frozen=True, kw_only=True)
class FaultSpec(ClientSpec):
    """The faults a run injects into its network, the same for the agents (their states and
    commands) and the world (the robots' radio, with onboard safety layers): one name from
    ``shoal run`` to both."""

    delay_ms: float = option(
        "--delay-ms", default=0.0, type=_MS,
        help="Fault injection: hold every message back this many ms, an agent's states and "
        "commands and (onboard) the robots' position broadcasts (a lockstep run only waits "
        "longer and stays exact; in realtime they arrive late).",
    )  # fmt: skip
    jitter_ms: float = _jitter_ms(
        help="Fault injection: … plus or minus up to this many ms, uniform (at most --delay-ms)."
    )
    drop_rate: float = option(
        "--drop-rate", default=0.0, type=_RATE, envvar="SHOAL_DROP_RATE",
        help="Fault injection, realtime only: lose this fraction of what is heard, an agent's "
        "neighbour states and (onboard) the robots' position broadcasts (seeded, counted; shoal "
        "run totals the agents' in its summary, `injected_drops`).",
    )  # fmt: skip
    drop_seed: int = option(
        "--drop-seed", default=0, envvar="SHOAL_DROP_SEED",
        help="Seed of the injected drops and delays.",
    )  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class RouterSpec(ChildSpec):
    """``shoal router``: a Zenoh router (zenoh-python in router mode)."""

    command: ClassVar[str] = "router"
    listen: tuple[str, ...] = _listen(
        help="Endpoint to listen on (repeatable) [default: tcp/127.0.0.1:7447; with --secure, "
        "tls/127.0.0.1:7447]."
    )
    connect: tuple[str, ...] = _connect(help="Another router to mesh with (repeatable).")
    zenoh_config: Path | None = _zenoh_config(help="A Zenoh JSON5 config file.")
    exit_after_run: str | None = option(
        "--exit-after-run", default=None, metavar="RUN", callback=check_run_id,
        help="Exit 0 once run RUN is over: its world came and went and every process of the "
        "run has left (one-shot deployments such as docker compose, where the router must end "
        "too).",
    )  # fmt: skip
    secure: Path | None = _secure()


@dataclass(frozen=True, kw_only=True)
class LoggerSpec(ClientSpec):
    """``shoal logger``: records a run into an MCAP file."""

    command: ClassVar[str] = "logger"
    out: Path = option(
        "--out", "-o", type=click.Path(dir_okay=False, path_type=Path), help="MCAP file."
    )
    force: bool = option("--force", default=False, is_flag=True, help="Overwrite OUT if it exists.")


def _plant(help: str) -> Any:
    return option("--plant", default=KINEMATICS, type=click.Choice(PLANTS), help=help)


def _dynamics() -> Any:
    return option(
        "--dynamics", default=None, type=click.Choice(list(PRESETS)),
        help="--plant mujoco: the robots' preset, in place of the scenario's dynamics: section "
        "(whose overrides still apply) [default: the scenario's, else gritsbot for unicycles "
        "and holonomic for single integrators; docs/physics.md].",
    )  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class WorldSpec(FaultSpec):
    """``shoal world``: the world process of a run. Its ``--ros-*`` options, when given, are
    taken as they are; ``shoal run`` gives all of them, resolved once (tools/ros2/config.py)."""

    command: ClassVar[str] = "world"
    scenario: str = argument(default="default")
    name: str | None = option(
        "--name", default=None,
        help="The scenario's name in the log and the summary [default: the scenario's own, or "
        "its file's]. `shoal run` hands over a scenario's text under its name.",
    )  # fmt: skip
    expect: tuple[str, ...] = option(
        "--expect", default=(), multiple=True,
        help="Also wait for this process's token before tick 0 (logger, monitor; repeatable).",
    )  # fmt: skip
    clock: Clock = option(
        "--clock", default=Clock.LOCKSTEP, type=click.Choice([str(c) for c in Clock]),
        help="lockstep: wait for every live agent each tick; realtime: a fixed wall-clock rate.",
    )  # fmt: skip
    speed: float = option(
        "--speed", default=1.0, type=click.FloatRange(min=0.01, max=100.0),
        help="realtime: simulated seconds per wall-clock second.",
    )  # fmt: skip
    safety_layer: SafetyLayer | None = option(
        "--safety-layer", default=None, type=click.Choice([str(r) for r in SafetyLayer]),
        help="What stands between a command and the robot's motion. onboard: each robot's own "
        "layer, with its own position, sensor and radio (no referee); referee: the world "
        "filters every command again with every robot's true position (a central, fresh view); "
        "none: commands applied as sent. Without referee the summary counts what one would "
        "have changed. [default: onboard in realtime, referee in lockstep]",
    )  # fmt: skip
    layer_epoch: float = option(
        "--layer-epoch", default=0.1, type=click.FloatRange(min=0.0, min_open=True),
        help="onboard: seconds of simulated time between the robots' common snapshots.",
    )  # fmt: skip
    start_timeout: float = _start_timeout(help="Seconds to wait for every agent.")
    robots: str = option(
        "--robots", default="simulated", type=click.Choice(["simulated", "ros2"]),
        help="simulated: the world integrates the robots' kinematics; ros2: it drives ROS 2 "
        "robots over rmw_zenoh instead (realtime, speed 1; docs/ros2.md): agent i's pose from "
        "/<prefix><i>/odom, its command as a Twist on /<prefix><i>/cmd_vel.",
    )  # fmt: skip
    plant: str = _plant(
        help="What moves the simulated robots: kinematics, the world's own (they move exactly "
        "as commanded); mujoco, robots with mass in the MuJoCo physics engine, which also "
        "judges their contacts (the physics extra; docs/physics.md)."
    )
    dynamics: str | None = _dynamics()
    ros_connect: tuple[str, ...] = _ros_connect(
        help="--robots ros2: the ROS 2 router (rmw_zenohd, or `shoal robots --listen`) "
        + _FROM_SCENARIO.format("tcp/127.0.0.1:7447")
    )
    ros_domain: int | None = option(
        "--ros-domain", default=None, type=_DOMAIN,
        help="--robots ros2: domain id " + _FROM_SCENARIO.format(0),
    )  # fmt: skip
    ros_distro: str | None = option(
        "--ros-distro", default=None, type=_DISTRO,
        help="--robots ros2: the robots' ROS 2 distribution " + _FROM_SCENARIO.format("jazzy"),
    )  # fmt: skip
    ros_prefix: str | None = option(
        "--ros-prefix", default=None,
        help="--robots ros2: agent i's robot is /<prefix><i> [default: the scenario's robots: "
        "namespaces, else /robot<i>].",
    )  # fmt: skip
    ros_namespaces: tuple[str, ...] = _ros_namespaces(
        help="--robots ros2: agent i's robot, by its namespace (/robot1), in agent order; "
        "repeat for each (in place of --ros-prefix)."
    )
    ros_pose: str | None = option(
        "--ros-pose", default=None, type=click.Choice(list(ROS_POSES)),
        help="--robots ros2: odom, nav_msgs/msg/Odometry on /<ns>/odom; pose, a motion "
        "capture's geometry_msgs/msg/PoseStamped on /<ns>/pose " + _FROM_SCENARIO.format("odom"),
    )  # fmt: skip
    pose_timeout: float | None = option(
        "--pose-timeout", default=None, type=click.FloatRange(min=0.01),
        help="--robots ros2: seconds after which a robot whose pose has not come is held still "
        + _FROM_SCENARIO.format(0.5),
    )  # fmt: skip


PLANT_OPTIONS = ("plant", "dynamics")
ROBOT_OPTIONS = ("robots", "ros_connect", "ros_domain", "ros_distro", "ros_prefix", "ros_pose",
                 "pose_timeout")  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class AgentSpec(FaultSpec):
    """``shoal agent``: one agent process."""

    command: ClassVar[str] = "agent"
    agent_id: int = option("--id", identity=True, type=click.IntRange(min=1), help="Agent id.")
    start_timeout: float = _start_timeout(help="Seconds to wait for the world.")


@dataclass(frozen=True, kw_only=True)
class RobotsSpec(ChildSpec):
    """``shoal robots``: simulated ROS 2 robots speaking rmw_zenoh (tools/ros2/fleet.py)."""

    command: ClassVar[str] = "robots"
    scenario: str = argument(default="default")
    count: int | None = option(
        "--count", "-n", default=None, type=click.IntRange(min=1),
        help="Robots to start: agents 1–N of SCENARIO [default: all of them].",
    )  # fmt: skip
    connect: tuple[str, ...] = _connect(
        help="Router to join as a client, as rmw_zenoh's nodes do [default: "
        "tcp/127.0.0.1:7447, rmw_zenohd's]."
    )
    listen: tuple[str, ...] = _listen(
        help="Be the router instead, listening here (no rmw_zenohd needed)."
    )
    domain: int | None = option(
        "--domain", default=None, type=_DOMAIN, envvar="ROS_DOMAIN_ID",
        help="ROS 2 domain id " + _FROM_SCENARIO.format(0),
    )  # fmt: skip
    distro: str | None = option(
        "--distro", default=None, type=_DISTRO,
        help="ROS 2 distribution the robots run (Humble's keys carry no type hash) "
        + _FROM_SCENARIO.format("jazzy"),
    )  # fmt: skip
    prefix: str | None = option(
        "--prefix", default=None,
        help="Robot i's namespace is /<prefix><i>: its topics /<prefix><i>/cmd_vel and "
        "/<prefix><i>/odom [default: the scenario's robots: namespaces, else /robot<i>].",
    )  # fmt: skip
    rate: float = option(
        "--rate", default=50.0, type=click.FloatRange(min=1.0, max=1000.0),
        help="Odometry messages per second per robot.",
    )  # fmt: skip
    latency_ms: float = option(
        "--latency-ms", default=0.0, type=_MS,
        help="Hold every odometry message back this many ms (a slow link).",
    )  # fmt: skip
    jitter_ms: float = _jitter_ms(
        help="… plus or minus up to this many ms, uniform (at most --latency-ms)."
    )
    cmd_timeout: float = option(
        "--cmd-timeout", default=0.5, type=click.FloatRange(min=0.01, max=60.0),
        help="Seconds without a cmd_vel after which a robot stops, as a real driver does.",
    )  # fmt: skip
    seed: int = option("--seed", default=0, help="Seed of the odometry delays.")
    plant: str = _plant(
        help="What moves the robots: kinematics, exactly as commanded (clamped to the "
        "scenario's limits); mujoco, robots with mass in the MuJoCo physics engine on the wall "
        "clock, which also judges their contacts (the physics extra; docs/physics.md)."
    )
    dynamics: str | None = _dynamics()


@dataclass(frozen=True, kw_only=True)
class GuardSpec(ClientSpec):
    """``shoal guard``: stops run RUN's ROS 2 robots if its world goes away. ``shoal run``
    gives it the robots the world drives, under the world's own option names."""

    command: ClassVar[str] = "guard"
    ros_namespaces: tuple[str, ...] = _ros_namespaces(
        required=True, help="A robot to stop, by its namespace (/robot1); repeat for each."
    )
    ros_connect: tuple[str, ...] = _ros_connect(
        help="The ROS 2 router [default: tcp/127.0.0.1:7447]."
    )
    ros_domain: int = option("--ros-domain", default=0, type=_DOMAIN, help="Domain id.")
    ros_distro: str = option(
        "--ros-distro", default="jazzy", type=_DISTRO, help="The robots' ROS 2 distribution."
    )
