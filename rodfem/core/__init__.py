"""The port-Hamiltonian system: the model protocol, state spaces, integration rules, ports,
materials, bodies, joints and the `System` that joins them (no model by name: those are in
rodfem.forms)."""
