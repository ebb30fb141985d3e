"""The paper's experiments and their reports, together: the simulator's sweep
(``sweep``, ``sweep_report``), the testbed's stationary study (``testbed_study``,
``testbed_study_report``) and the edge-cloud runs (``edge_cloud_*``). The tracking
application's flight study stays with the application (``wiswarm_apps.tracking.study``):
the middleware does not import its applications."""

from wiswarm_zenoh.experiments.testbed_study import best_of_grid, share_fps

__all__ = ["best_of_grid", "share_fps"]
