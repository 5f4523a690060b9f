"""Run-time guards shared by every layer: interrupts (signals between steps), limits (memory,
step counts), standard streams."""
