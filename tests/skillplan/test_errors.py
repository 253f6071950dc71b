"""One hierarchy of input errors: every package's errors derive from the project's root, so a
caller catches bad input of any package with one class."""
from __future__ import annotations

import numpy as np
import pytest

import clamp
import robots
import scenes
import tlgc
from scenes.errors import InvalidArgumentError


@pytest.mark.parametrize("base", [robots.RobotError, scenes.errors.ScenesError, clamp.ClampError,
                                  tlgc.TLGCError, tlgc.TLGCArgumentError])
def test_every_package_base_derives_from_the_root(base):
    assert issubclass(base, InvalidArgumentError) and issubclass(base, ValueError)


def test_bad_input_of_every_package_is_caught_by_the_root(jaco):
    calls = [
        lambda: robots.load_robot("no-such-arm"),
        lambda: scenes.Box([0.0, 0.0, 0.0], [-1.0, 1.0, 1.0]),
        lambda: clamp.PlannerConfig().with_(no_such_field=1),
        lambda: tlgc.fit_cylinder(np.zeros((1, 10, 3)), "circle"),
        lambda: jaco.fk(np.full(jaco.n, np.nan)),
    ]
    for call in calls:
        with pytest.raises(InvalidArgumentError):
            call()
