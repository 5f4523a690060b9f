"""What a run writes: history, summary, frames (VTK), sections, pictures and checkpoints."""
