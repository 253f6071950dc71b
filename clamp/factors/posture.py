"""Posture: every state's configuration held near a reference trajectory (the free plan),
e_i = q_i - q_ref_i (n,), noise sigma [rad] per joint. Linear.

The obstacle plan's tie to the plan the skill makes in an empty scene: the workspace prior
fixes where the hand goes, not how the arm holds it, so without it an obstacle's hinge can
turn the wrist or flip the elbow at no cost to the skill (issue 19: 6-8x the joint travel of
the free plan, 60-80 deg of added hand rotation). With it, the arm keeps the free plan's
posture and moves only as far as the obstacle demands.
"""
from __future__ import annotations

from .joint_target import JointTargetFamily


class PostureFamily(JointTargetFamily):
    """One factor per state: indices (K,), reference configurations (K, n) [rad], sigmas (K,)."""

    name = "posture"
