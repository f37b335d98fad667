"""Classical base placement: where should the base stop, by geometry alone?

``place(method, depth, intrinsics, camera_to_base, target_mask, robot, ...)`` takes what
:func:`momakitchen.predict` takes and returns the same
:class:`~momakitchen.models.inference.Prediction`, for the methods of
:data:`CLASSICAL_METHODS`: ``ring`` (a standoff band from the robot's reach) and
``reachability`` (the arm's reachability, sampled from its URDF, inverted at the target's
grasp pose; :class:`ReachabilityMap`). See docs/PLACEMENT.md.
"""

from momakitchen.placement.methods import CLASSICAL_METHODS, METHODS, place
from momakitchen.sim.reachability import ReachabilityMap

__all__ = ["CLASSICAL_METHODS", "METHODS", "ReachabilityMap", "place"]
