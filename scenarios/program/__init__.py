"""What the planning (scenarios.offline) and RAPID (scenarios.rapid) share beneath them both:
the offline program as a value (`program_types`: its operations, as authored, planned and
executed) and the one motion both make, the safe tool change (`tool_change`)."""
