"""Reading results back and the measures the validation cases compare (serial)."""
from .elements import element_profiles
from .frames import axial_profiles, read_frame, frame_times, read_summary
from .measures import (convex_hull_area, foot_diameter, taylor_length_and_diameter,
                       taylor_shape, wave_bar_stress, rms_error)
from .hertz import dropped_sphere_measures, hertz_answer, hertz_measures
from .spin import affine_spin, oblique_impact, spin_about_centroid
from .shock import planar_shock_errors, rankine_hugoniot, shocked_state
from .contact import (body_history, body_index, body_points, connected_pieces, count_pieces,
                      energy_steps, free_after, min_distance, perforation, read_history,
                      residual_velocity, rolling_sphere_slips, rolling_sphere_travel, travel,
                      until_separation)

__all__ = ["axial_profiles", "element_profiles", "read_frame", "frame_times", "read_summary",
           "convex_hull_area", "foot_diameter", "taylor_length_and_diameter", "taylor_shape",
           "wave_bar_stress", "rms_error",
           "dropped_sphere_measures", "hertz_answer", "hertz_measures",
           "planar_shock_errors", "rankine_hugoniot", "shocked_state",
           "body_history", "body_index", "body_points", "connected_pieces", "count_pieces",
           "energy_steps", "free_after", "min_distance", "perforation", "read_history",
           "residual_velocity", "rolling_sphere_slips", "rolling_sphere_travel", "travel",
           "until_separation", "affine_spin", "oblique_impact", "spin_about_centroid"]
