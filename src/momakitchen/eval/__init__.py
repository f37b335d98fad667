"""Evaluation: map metrics of a trained run on a dataset (:mod:`.evaluate`), closed-loop
manipulation success (:mod:`.msr`) and the benchmark report (:mod:`.report`). The metric
functions themselves are :mod:`momakitchen.metrics`."""
