"""Pictures of frames, scans and detections (needs the optional ``plot`` extra)."""

__all__ = []
