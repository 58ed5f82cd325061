"""Figures (:mod:`~adaptnav.viz.plots`), the HTML report (:mod:`~adaptnav.viz.report`) and the
results pages' Markdown helpers (:mod:`~adaptnav.viz.pages`)."""
