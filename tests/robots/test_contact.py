"""One contact record and one wording for the robot's two distance checks (robots.contact): the
obstacle check (robots.collision_check) and the self-collision check (robots.self_collision)
report the same Contact type, worded by the same functions the verdict uses."""
from __future__ import annotations

import json

import numpy as np

import clamp.planning.clearance as clearance
from robots import collision_check, self_collision
from robots.collision_check import CollisionChecker
from robots.contact import Contact, collision_reason, describe_contact
from robots.distance_search import PairSearch
from robots.self_collision import SelfContact, self_collision_report
from scenes import Box
from scenes.coal_shapes import coal_obstacles

PROBE_Q = np.array([0.8342, 2.7134, 4.9144, 0.894, 2.2859, 0.0])
PROBE_BOX = Box([0.2271, -0.3773, 0.1763], [0.04, 0.04, 0.04])


def test_obstacle_and_self_collision_reports_share_the_contact_type(jaco):
    q = np.stack([PROBE_Q, PROBE_Q])
    obstacle = CollisionChecker(jaco, coal_obstacles([PROBE_BOX], names=["probe_box"])).check(q, [0.0, 1.0])
    own = self_collision_report(jaco, q, [0.0, 1.0])
    assert type(obstacle.nearest) is Contact and type(own.nearest) is Contact
    assert SelfContact is Contact and collision_check.Contact is Contact
    # obstacle: the other side is the obstacle; self-collision: another link and its geometry
    assert not obstacle.nearest.is_self and obstacle.nearest.obstacle == "probe_box"
    assert obstacle.nearest.other == "probe_box" and obstacle.nearest.link_b is None
    assert own.nearest.is_self and own.nearest.obstacle is None
    assert (own.nearest.link_a, own.nearest.link_b) == (own.nearest.link, own.nearest.other)
    assert own.nearest.geometry_b == own.nearest.other_geometry is not None
    assert own.nearest.link in jaco.frame_names and own.nearest.other in jaco.frame_names
    # one wording: the verdict's and the self-collision report's
    assert clearance.collision_reason is collision_reason and clearance.describe_contact is describe_contact
    assert collision_reason(obstacle) == "collision: " + describe_contact(obstacle.nearest, obstacle.geometry)
    assert collision_reason(own) == own.reason          # None: the probe does not fold the arm
    # each check's JSON keeps its field names
    assert set(json.loads(json.dumps(obstacle.to_dict()))["nearest"]) == {
        "link", "geometry", "obstacle", "index", "time", "distance"}
    assert set(json.loads(json.dumps(own.to_dict()))["nearest"]) == {
        "link_a", "link_b", "geometry_a", "geometry_b", "index", "time", "distance"}


def test_one_wording_for_both_kinds_of_contact():
    obstacle = Contact("finger", "finger_0", "box_0", 12.25, 3.1, -0.0012)
    assert describe_contact(obstacle, "urdf") == ("link finger 1.2 mm inside box_0 at state 12.25 (t = 3.10 s), "
                                                  "on the URDF collision geometry")
    assert describe_contact(Contact("finger", "finger#3", "box_0", 4.0, None, 0.002), "spheres") == (
        "link finger 2.0 mm from box_0 at state 4, on the collision spheres (the robot has no collision geometry)")
    own = Contact("l1", "l1_0", "l6", 245.25, 39.24, -0.0279, "l6_0")
    assert describe_contact(own) == "l1 and l6 overlap by 27.9 mm at state 245.25 (t = 39.24 s)"


def test_both_checks_run_the_one_search():
    assert issubclass(collision_check._Search, PairSearch) and issubclass(self_collision._Search, PairSearch)
