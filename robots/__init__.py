"""Kinematics of real arms: Pinocchio models, joint limits, end effector, collision spheres,
vectorized forward kinematics with Jacobians, and inverse kinematics for initialisation."""
import lazy_loader

# the names and where they live: __init__.pyi (submodules load on first use: ``import robots``
# does not load Pinocchio, SciPy or TOPP-RA)
__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
