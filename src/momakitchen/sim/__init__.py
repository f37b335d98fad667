"""PyBullet worlds, manipulation trials and affordance labels."""

from momakitchen.sim.world import BodyInfo, TargetInfo, World

__all__ = ["BodyInfo", "TargetInfo", "World"]
