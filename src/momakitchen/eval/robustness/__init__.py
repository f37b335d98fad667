"""The robustness track: a model on the frames a real robot would give it.

For each configuration of a split, the view that ``msr`` picks for the same seed is judged
under each named corruption (:data:`momakitchen.perception.sensors.CORRUPTIONS`: sensor
noise, segmenter masks, calibration errors, monocular depth). ``clean`` is that view
exactly as ``msr`` scores it (the episode's stored clouds, the same settings), so the clean
row is ``msr``'s figure on the same views; under every other corruption the stored render
is corrupted and goes through the real-robot path
(:func:`momakitchen.perception.live.frame_inputs`, floor-plane correction included). The
model's Top-k base positions, in the frame the robot believes, are driven to and tried
with the labelling's own trial in PyBullet. Map metrics compare the predicted map with
the ground truth at the same floor points (the stored labels for ``clean``; elsewhere the
labels' interpolation at the points, :func:`momakitchen.sim.labels.floor_affordance`).

Views whose target lies beyond the sensor's working range are counted apart (a robot
there should move closer, not trust a model); every other failure to predict is an error
counted by its cause.

The parts: :mod:`.views` (which view, what a model is given of it, a prediction),
:mod:`.track` (a run over a split), :mod:`.tables` (summaries, tables, figure) and
:mod:`.export` (the inputs for a method that runs elsewhere).
"""
