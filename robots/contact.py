"""The contact record of the robot's distance checks and its wording, one for both.

:class:`Contact` is the nearest (or deepest) pair a check found: a link geometry and either an
obstacle (:class:`robots.collision_check.CollisionChecker`) or another link of the same robot
(:func:`robots.self_collision.self_collision_report`), where along the trajectory, and coal's
signed distance. :func:`describe_contact` words one, :func:`collision_reason` words a report
that found a collision (the verdict's reasons)::

    contact.link, contact.geometry          # the link (frame) and its collision object
    contact.other                           # the obstacle's name, or the other link
    contact.other_geometry                  # the other link's collision object; None: an obstacle
    contact.index, contact.time, contact.distance
    contact.obstacle                        # other for an obstacle contact, else None
    contact.link_a, .link_b, .geometry_a, .geometry_b   # the self-collision names (link_b: None
                                                        # for an obstacle contact)
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Contact:
    """The nearest (or deepest) pair of a distance check.

    link: frame name of the link; geometry: name of its collision object (or sphere); other: the
    obstacle's name (obstacle check) or the other link's frame name (self-collision);
    index: fractional support-state index (12.25 = a quarter of the way from state 12 to 13);
    time [s] at that point when time stamps were given, else None; distance [m]: coal's signed
    distance on the collision geometry, negative when overlapping (the depth);
    other_geometry: the other link's collision object (self-collision), None for an obstacle.
    """

    link: str
    geometry: str
    other: str
    index: float
    time: float | None
    distance: float
    other_geometry: str | None = None

    @property
    def is_self(self) -> bool:
        """Whether the other side is a link of the same robot (a self-collision contact)."""
        return self.other_geometry is not None

    @property
    def obstacle(self) -> str | None:
        """The obstacle's name; None for a self-collision contact."""
        return None if self.is_self else self.other

    @property
    def link_a(self) -> str:
        return self.link

    @property
    def link_b(self) -> str | None:
        """The other link; None for an obstacle contact."""
        return self.other if self.is_self else None

    @property
    def geometry_a(self) -> str:
        return self.geometry

    @property
    def geometry_b(self) -> str | None:
        return self.other_geometry

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: link, geometry, obstacle, index, time, distance for an obstacle contact;
        link_a, link_b, geometry_a, geometry_b, index, time, distance for a self-collision one
        (the fields each check has always written)."""
        if self.is_self:
            names = {"link_a": self.link, "link_b": self.other, "geometry_a": self.geometry,
                     "geometry_b": self.other_geometry}
        else:
            names = {"link": self.link, "geometry": self.geometry, "obstacle": self.other}
        return {**names, "index": self.index, "time": self.time, "distance": self.distance}


def time_at(index: float, time: np.ndarray | None) -> float | None:
    """The time [s] at fractional support-state index ``index`` (linear between the stamps
    time (T,)); None without time stamps."""
    if time is None:
        return None
    T = len(time)
    i = min(int(math.floor(index)), T - 1)
    return float(time[i] + (index - i) * (time[i + 1] - time[i])) if i < T - 1 else float(time[i])


def describe_contact(contact: Contact, geometry: str = "urdf", clock: str = "t") -> str:
    """One phrase naming both sides, where and how far, e.g. "link j2s6s200_link_finger_tip_1
    1.2 mm inside box_0 at state 12.25 (t = 3.10 s), on the URDF collision geometry" (an
    obstacle; geometry: "urdf" or "spheres", what was measured) or "j2s6s200_link_1 and
    j2s6s200_link_6 overlap by 27.9 mm at state 245.25 (t = 39.24 s)" (self-collision); ``clock``
    names the time ("skill time t" for a plan's support states)."""
    when = "" if contact.time is None else f" ({clock} = {contact.time:.2f} s)"
    depth = contact.distance * 1000.0
    if contact.is_self:
        return f"{contact.link} and {contact.other} overlap by {-depth:.1f} mm at state {contact.index:.2f}{when}"
    how = f"{-depth:.1f} mm inside" if depth < 0 else f"{depth:.1f} mm from"
    index = f"{round(contact.index, 2):g}"
    source = ("the URDF collision geometry" if geometry == "urdf"
              else "the collision spheres (the robot has no collision geometry)")
    return f"link {contact.link} {how} {contact.other} at state {index}{when}, on {source}"


def collision_reason(report: Any, clock: str = "t") -> str | None:
    """The verdict's reason when ``report`` (a CollisionReport or a SelfCollisionReport) found a
    collision, else None: "collision: ..." / "self-collision: ...; N support states in
    collision" with :func:`describe_contact`, or "collision check failed: ..." (a fault)."""
    if report is None or not report.collision:
        return None
    fault = getattr(report, "fault", None)
    if fault is not None:
        return f"collision check failed: {fault}"
    contact = report.nearest
    if contact is None:
        return None
    if not contact.is_self:
        return f"collision: {describe_contact(contact, report.geometry, clock)}"
    count = int(report.states_in_collision.sum())
    return (f"self-collision: {describe_contact(contact, report.geometry, clock)}; {count} support "
            f"state{'s' if count != 1 else ''} in collision")
