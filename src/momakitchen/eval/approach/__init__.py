"""The approach track: the last mile as a robot drives it (docs/APPROACH.md).

For each configuration of a split and each start (``near``: the view ``msr`` judges for
the same seed; ``far``: the farthest free pose 3.8-6 m from the target, within +-45 deg
of the direction it faces, that sees it), every method drives the base from the start to
a goal and the labelling's trial runs where the base really stopped:

1. **look**: render the robot's RGB-D frame at its *true* pose (the dataset's renderer),
   apply the perception preset (sensor noise, segmenter mask error, calibration error),
   and run the real-robot path :func:`momakitchen.predict` on it (or a server's
   ``/predict``);
2. **fuse**: the looks' maps in the odometry frame (:class:`~momakitchen.deploy.fusion.MapFusion`),
   the goal the best fused cell the base can reach;
3. **drive**: a shortest collision-free path on the room's free space, driven with
   odometry drift and checked in PyBullet at every step (:mod:`momakitchen.sim.motion`);
   the policy may stop on the way and look again (``relook``, ``uncertain``);
4. **stop**: the controller stops with an error and the base turns, by odometry, to face
   the target; the trial runs at the true final pose.

Baselines drive the same way with the same errors: ``oracle`` (the ground truth's best
successful cell, known from the start), ``nearest`` (the free cell nearest the target),
``random`` (a free cell within the arm's reach of it).
"""
