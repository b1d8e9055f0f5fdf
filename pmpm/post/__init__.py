"""Reading results back and the measures the validation cases compare (serial)."""
from .frames import axial_profiles, read_frame, frame_times, read_summary
from .measures import taylor_length_and_diameter, wave_bar_stress, rms_error

__all__ = ["axial_profiles", "read_frame", "frame_times", "read_summary", "taylor_length_and_diameter",
           "wave_bar_stress", "rms_error"]
