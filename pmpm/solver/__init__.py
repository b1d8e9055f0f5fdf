"""One explicit step as named phases, time-step control and the run loop."""
