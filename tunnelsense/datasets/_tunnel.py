"""Placeholder, being replaced by the tunnel simulator (issue 3)."""

TUNNEL_SCENARIOS = ()


def make_tunnel_tour(*args, **kwargs):
    raise NotImplementedError("the tunnel simulator is not written yet")
