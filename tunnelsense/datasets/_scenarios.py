"""The names of the simulator's scenarios (no imports: the command line lists them)."""

__all__ = ["STREET_SCENARIOS", "TUNNEL_SCENARIOS"]

TUNNEL_SCENARIOS = ("light", "heavy", "curved", "randomized")
STREET_SCENARIOS = ("sparse", "dense", "tilted", "crowded", "hard", "randomized")
