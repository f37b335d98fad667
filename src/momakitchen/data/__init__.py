"""Datasets: the sample / batch contract (:mod:`.batch`), synthetic episodes (:mod:`.synthetic`)."""
