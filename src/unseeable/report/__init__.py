"""Reports of estimates: an interactive 3-D page of an estimate (:func:`write_estimate_page`)."""

from unseeable.report.viewer import (
    estimate_page_html,
    estimate_scene,
    log_feature_keys,
    scene_page_html,
    write_estimate_page,
    write_scene_page,
)

__all__ = ["estimate_page_html", "estimate_scene", "log_feature_keys", "scene_page_html",
           "write_estimate_page", "write_scene_page"]
