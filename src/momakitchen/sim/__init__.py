"""PyBullet worlds, manipulation trials and affordance labels.

:mod:`.config` (trial and dense-map settings, trial stages) is plain data; the other
modules load PyBullet, so this package imports none of them eagerly.
"""
