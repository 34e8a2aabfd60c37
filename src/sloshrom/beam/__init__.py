"""The sloshing beam: modal structure, coupled simulation and the damping analyses."""
