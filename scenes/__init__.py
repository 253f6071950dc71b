"""The world and what was shown in it: obstacles, scenes, signed distance fields,
demonstration sets (import/export, ROS 2 bags, resampling, time alignment) and synthetic skills."""
import lazy_loader

# the names and where they live: __init__.pyi (submodules load on first use: ``import scenes``
# does not load SciPy or rosbags)
__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
