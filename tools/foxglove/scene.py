"""What the 3D panel draws: shoal's scene layers as foxglove.SceneUpdate / FrameTransforms.

One topic per layer, so each can be switched on and off in the panel, and so the static layers
(drawn once) survive a seek: Foxglove backfills the latest message of each topic, and a layer that
shared a topic with the moving agents would be replaced by their next update.

Sizes: what is physical is drawn true to scale (an agent's body of radius ``agent_radius``, the
obstacles, the sensing radius), however small; what is only a marker (a follower's demanded slot)
is drawn at ``mark``, a size read from the formation. Labels and lines keep their size in pixels,
so the swarm stays readable when zoomed out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from shoal.bus.messages import TickRecord
from shoal.geometry.path import path_positions
from shoal.geometry.vectors import shaped
from shoal.tools.foxglove.msgs import (
    LINE_LIST,
    LINE_LOOP,
    LINE_STRIP,
    RGBA,
    Json,
    arrow,
    circle,
    cylinder,
    dashes,
    entity,
    frame_transforms,
    line,
    scene_update,
    sphere,
    text,
    vec3,
    vec3s,
    yaw,
)
from shoal.world.scenario import Scenario
from shoal.world.unicycle import body_centres

LEADER: RGBA = (0.12, 0.47, 0.71, 1.0)
FOLLOWER: RGBA = (0.17, 0.63, 0.17, 1.0)
EVADING: RGBA = (1.0, 0.5, 0.05, 1.0)  # Ω_i = 1
GONE: RGBA = (0.5, 0.5, 0.5, 0.7)  # process gone, held still by the world
EDGE: RGBA = (0.35, 0.45, 0.6, 0.9)
DROPPED: RGBA = (0.86, 0.1, 0.1, 0.9)  # the edge to an evading agent (Algorithm 2)
OBSTACLE: RGBA = (0.45, 0.3, 0.25, 0.85)
MARGIN: RGBA = (0.45, 0.3, 0.25, 0.5)
SENSING: RGBA = (0.3, 0.3, 0.8, 0.35)
PATH: RGBA = (0.5, 0.5, 0.5, 0.6)
SLOT: RGBA = (0.17, 0.63, 0.17, 0.6)
MOVER: RGBA = (0.5, 0.0, 0.5, 0.85)  # a moving obstacle (a person)

PILLAR_M = 1.0  # height of a 2-D obstacle's pillar (the plane is z = 0)
PATH_SAMPLES = 2000  # at most, along the leader's path


def frame(agent_id: int) -> str:
    """The Foxglove frame that follows agent ``agent_id`` (see /shoal/tf)."""
    return f"agent_{agent_id}"


@dataclass(frozen=True)
class Layers:
    """The scene layers of one scenario; each method returns one message of its topic."""

    scenario: Scenario

    @property
    def mark(self) -> float:
        """m: size of the markers that are not physical objects."""
        return max(4 * self.scenario.agent_radius, 0.05 * self.scenario.formation_radius)

    def world(self, ns: int) -> Json:
        """Obstacles (body, and the safety margin ρ the evasion keeps) and the leader's path."""
        s = self.scenario
        rho = s.control.safety_margin
        entities = []
        for k in s.standing_ids:  # moving ones are drawn with the agents, tick by tick
            o = s.obstacles[k]
            meta = {"index": str(k), "radius_m": str(o.radius), "safety_margin_m": str(rho)}
            name, centre = f"obstacle/{k}", vec3(o.centre)
            if s.dim == 3:
                body = sphere(centre, 2 * o.radius, OBSTACLE)
                margin = sphere(centre, 2 * (o.radius + rho), (*MARGIN[:3], 0.15))
                entities.append(entity(ns, name, metadata=meta, spheres=[body, margin]))
                continue
            pillar = vec3((o.centre[0], o.centre[1], PILLAR_M / 2))
            edges = [
                line(LINE_LOOP, circle(o.radius), OBSTACLE, 2.0, origin=centre),
                line(LINE_LOOP, circle(o.radius + rho), MARGIN, 1.0, origin=centre),
            ]
            body = cylinder(pillar, 2 * o.radius, PILLAR_M, OBSTACLE)
            entities.append(entity(ns, name, metadata=meta, cylinders=[body], lines=edges))
        samples = min(s.steps + 1, PATH_SAMPLES)
        route = vec3s(path_positions(s.path, np.linspace(0.0, s.duration, samples)))
        entities.append(entity(ns, "path", lines=[line(LINE_STRIP, route, PATH, 1.0)]))
        return scene_update(entities)

    def sensing(self, ns: int) -> Json:
        """Each agent's sensing radius d (and trigger radius d̄), locked to the agent's frame:
        published once, carried along by /shoal/tf."""
        c = self.scenario.control
        meta = {
            "sensing_radius_m": str(c.sensing_radius),
            "trigger_radius_m": str(c.trigger_radius),
        }
        spheres, lines = [], []
        if self.scenario.dim == 3:
            spheres = [sphere(vec3((0, 0, 0)), 2 * c.sensing_radius, (*SENSING[:3], 0.05))]
        else:
            lines = [
                line(LINE_LOOP, circle(c.sensing_radius), SENSING, 1.0),
                line(LINE_LOOP, circle(c.trigger_radius), (*SENSING[:3], 0.15), 1.0),
            ]
        return scene_update(
            [
                entity(
                    ns, f"sensing/{a.agent_id}", frame_id=frame(a.agent_id), frame_locked=True,
                    metadata=meta, spheres=spheres, lines=lines,
                )
                for a in self.scenario.agents
            ]
        )  # fmt: skip

    def frames(self, ns: int, where: list[Json], headings: Sequence[float] = ()) -> Json:
        """Frame ``agent_<i>`` at agent i's position (``where``: vec3s of a record's positions),
        its x axis along the unicycle's ``headings`` (rad) where the record has them."""
        turns = [yaw(h) for h in headings]
        return frame_transforms(
            ns, ((frame(i + 1), p) for i, p in enumerate(where)), rotations=turns
        )

    def agents(
        self, ns: int, r: TickRecord, where: list[Json], velocities: Sequence[Sequence[float]]
    ) -> Json:
        """Each agent's body, ``velocities`` (an arrow to where it would be in 1 s) and label; and
        ``slots``: each follower's demanded slot R(θ_i)δ_i/σ_i about the leader (a cross), joined
        to the follower (its formation error, as a line)."""
        s = self.scenario
        entities = []
        ells = s.lookaheads
        unicycles = ells is not None and len(r.headings) == s.n
        if ells is not None and unicycles:  # each body's centre, l behind its point
            axles = vec3s(body_centres(np.asarray(r.positions), np.asarray(r.headings), ells))
        for i, p in enumerate(where):
            rgba = _agent_colour(r, i)
            label = f"{i + 1}" + (" leader" if i == 0 else "")
            label += " Ω" if r.omega[i] else ""
            label += " gone" if not r.alive[i] else ""
            tag = text({**p, "z": p["z"] + 2 * s.agent_radius}, label, rgba)
            velocity = arrow(p, velocities[i], rgba, s.agent_radius)
            arrows = [velocity] if velocity is not None else []
            meta = {
                "omega": str(r.omega[i]).lower(),
                "alive": str(r.alive[i]).lower(),
                "sigma": f"{r.sigma[i]:.6g}",
                "theta_rad": f"{r.theta[i]:.6g}",
            }
            if ells is not None and unicycles and ells[i] > 0:  # (a mixed swarm's single: 0)
                spheres = self._unicycle(p, axles[i], r.headings[i], float(ells[i]), rgba, arrows)
                meta["heading_rad"] = f"{r.headings[i]:.6g}"
            else:
                spheres = [sphere(p, 2 * s.agent_radius, rgba)]
            entities.append(
                entity(ns, f"agent/{i + 1}", metadata=meta, spheres=spheres, texts=[tag],
                       arrows=arrows)
            )  # fmt: skip
        entities.append(entity(ns, "slots", lines=self._slots(r, where)))
        entities += self._movers(ns, r)
        return scene_update(entities)

    def _unicycle(
        self, point: Json, axle: Json, heading: float, ell: float, rgba: RGBA, arrows: list[Json]
    ) -> list[Json]:
        """A unicycle: its body about the ``axle`` l behind ``point``, a small dot at the point
        the laws move, and (added to ``arrows``) its heading from the axle to the body's rim."""
        s = self.scenario
        reach = ell + s.agent_radius
        e = (math.cos(heading), math.sin(heading))
        ahead = arrow(axle, [reach * c for c in e], rgba, s.agent_radius / 4)
        if ahead is not None:
            arrows.append(ahead)
        dot = (*rgba[:3], 1.0)
        return [sphere(axle, 2 * s.agent_radius, (*rgba[:3], 0.6 * rgba[3])),
                sphere(point, s.agent_radius / 2, dot)]  # fmt: skip

    def _movers(self, ns: int, r: TickRecord) -> list[Json]:
        """Each moving obstacle where it is at ``r``: its body (a pillar in 2-D), its guard
        circle r + ρ, an arrow of one second of its velocity, and its label."""
        s, rho = self.scenario, self.scenario.control.safety_margin
        out = []
        for k, c, w in zip(s.mover_ids, r.mover_centres, r.mover_velocities, strict=True):
            o = s.obstacles[k]
            centre = vec3(c)
            speed = math.hypot(*w)
            meta = {"index": str(k), "radius_m": str(o.radius), "speed_m_s": f"{speed:.4g}",
                    "u_max_m_s": str(o.speed_cap)}  # fmt: skip
            tag = text({**centre, "z": centre["z"] + PILLAR_M}, f"obstacle {k}", MOVER)
            walk = arrow(centre, list(w), MOVER, o.radius / 2)
            arrows = [walk] if walk is not None else []
            if s.dim == 3:
                spheres = [sphere(centre, 2 * o.radius, MOVER),
                           sphere(centre, 2 * (o.radius + rho), (*MOVER[:3], 0.15))]  # fmt: skip
                out.append(entity(ns, f"mover/{k}", metadata=meta, spheres=spheres,
                                  texts=[tag], arrows=arrows))  # fmt: skip
                continue
            pillar = cylinder(vec3((c[0], c[1], PILLAR_M / 2)), 2 * o.radius, PILLAR_M, MOVER)
            ring = line(LINE_LOOP, circle(o.radius + rho), (*MOVER[:3], 0.5), 1.0, origin=centre)
            out.append(entity(ns, f"mover/{k}", metadata=meta, cylinders=[pillar], lines=[ring],
                              texts=[tag], arrows=arrows))  # fmt: skip
        return out

    def _slots(self, r: TickRecord, where: list[Json]) -> list[Json]:
        s, h = self.scenario, self.mark / 2
        leader = np.asarray(r.positions[0], dtype=np.float64)
        slots = [
            leader + shaped(np.asarray(a.offset), sigma=r.sigma[i], theta=r.theta[i])
            for i, a in enumerate(s.agents)
            if i > 0
        ]
        arms = [np.asarray(d + (0.0,) * (s.dim - 2)) for d in ((-h, 0), (h, 0), (0, -h), (0, h))]
        crosses = vec3s([slot + arm for slot in slots for arm in arms]) if slots else []
        errors = [p for slot, at in zip(slots, where[1:], strict=True) for p in (vec3(slot), at)]
        return [
            line(LINE_LIST, crosses, SLOT, 1.5),
            line(LINE_LIST, errors, (*SLOT[:3], 0.35), 1.0),
        ]

    def graph(self, ns: int, r: TickRecord, where: list[Json]) -> Json:
        """The sensing graph's edges in three entities: ``edges/followed`` (solid),
        ``edges/dropped`` (dashed red: an agent that senses along the edge sees the other end
        evade, Ω, and drops it: Algorithm 2) and ``edges/gone`` (dashed grey: the other end's
        process is gone). Their metadata name the edges and why."""
        groups: dict[str, tuple[list[Json], list[str]]] = {
            "followed": ([], []), "dropped": ([], []), "gone": ([], [])
        }  # fmt: skip
        for a, b in self.scenario.edges:
            pa, pb = where[a - 1], where[b - 1]
            state, why = self._edge_state(r, a - 1, b - 1)
            points, names = groups[state]
            points.extend([pa, pb] if state == "followed" else dashes(pa, pb))
            names.append(f"{a}-{b}" + (f" ({why})" if why else ""))
        style = {"followed": (EDGE, 2.0), "dropped": (DROPPED, 1.5), "gone": (GONE, 1.5)}
        return scene_update(
            [
                entity(
                    ns, f"edges/{state}", metadata={"edges": ", ".join(names)},
                    lines=[line(LINE_LIST, points, *style[state])],
                )
                for state, (points, names) in groups.items()
            ]
        )  # fmt: skip

    def _edge_state(self, r: TickRecord, a: int, b: int) -> tuple[str, str]:
        """("followed", ""), or ("dropped" | "gone", why) when an agent that senses along this
        edge does not follow it this tick (agent/controller.py: a neighbour that is evading or
        gone is not followed). The leader follows nobody: its own side never counts."""
        adjacency = self.scenario.adjacency
        for i, j in ((a, b), (b, a)):
            if i == 0 or adjacency[i, j] == 0 or not r.alive[i]:
                continue
            if not r.alive[j]:
                return "gone", f"agent {j + 1} gone"
            if r.omega[j]:
                return "dropped", f"agent {j + 1} evades"
        return "followed", ""

    def trails(self, ns: int, history: list[list[Json]], r: TickRecord, where: list[Json]) -> Json:
        """The path each agent, then each moving obstacle, has travelled: ``history`` (sampled
        points, agents first) up to ``where`` it is in ``r``."""
        entities = []
        n = self.scenario.n
        for i, points in enumerate(history[:n]):
            rgba = (*_agent_colour(r, i)[:3], 0.6)
            strip = line(LINE_STRIP, [*points, where[i]], rgba, 1.5)
            entities.append(entity(ns, f"trail/{i + 1}", lines=[strip]))
        for q, points in enumerate(history[n:]):
            strip = line(LINE_STRIP, [*points, where[n + q]], (*MOVER[:3], 0.5), 1.0)
            entities.append(entity(ns, f"trail/mover/{self.scenario.mover_ids[q]}", lines=[strip]))
        return scene_update(entities)


def _agent_colour(r: TickRecord, i: int) -> RGBA:
    if not r.alive[i]:
        return GONE
    if r.omega[i]:
        return EVADING
    return LEADER if i == 0 else FOLLOWER
