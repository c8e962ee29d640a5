"""Genuine detector files and a hand-written zip, for the model-file tests."""

import hashlib
import io
import struct
import zipfile
import zlib

import numpy as np

from tunnelsense import make_indicator_pipeline, make_parking_pipeline, to_xy
from tunnelsense.datasets import make_street_scans, make_tunnel_tour
from tunnelsense.io import save_model, write_run, write_tour

LAST = {"tunnel": "motion", "street": "cluster"}


def make_genuine(folder):
    """Two genuine detectors saved in ``folder``, their tour and run, and what they detect."""
    tour = make_tunnel_tour(120, scenario="light", random_state=5, name="tour")
    X, y, _ = to_xy([tour])
    tunnel = make_indicator_pipeline(random_state=0).fit(X, y)
    run = make_street_scans(300, random_state=5, name="run")
    Xs, ys, _ = to_xy([run])
    street = make_parking_pipeline().fit(Xs, ys)
    return {
        "tunnel": save_model(tunnel, folder / "tunnel.skops"),
        "street": save_model(street, folder / "street.skops"),
        "tour": write_tour(tour, folder / "tour"),
        "run": write_run(run, folder / "run"),
        "X": {"tunnel": X, "street": Xs},
        "detections": {"tunnel": _detections(tunnel, X), "street": _detections(street, Xs)},
    }


def _detections(model, X):
    """What a user sees: the detections of every frame or scan."""
    return [np.asarray(p.payload["detections"] if hasattr(p, "payload") else p).tolist()
            for p in model.predict(X)]


def _members(path):
    src = zipfile.ZipFile(io.BytesIO(path.read_bytes()))
    return {i.filename: src.read(i.filename) for i in src.infolist()}


def _zip(members, raw=None) -> bytes:
    """A zip of ``members`` (name -> bytes), plus ``raw`` members (name -> (deflated
    bytes, crc, size)), with tunnelsense's checksum, written by hand."""
    entries = []
    for name, payload in members.items():
        c = zlib.compressobj(6, zlib.DEFLATED, -15)
        entries.append((name, c.compress(payload) + c.flush(), zlib.crc32(payload),
                        len(payload)))
    entries += [(n, *v) for n, v in (raw or {}).items()]
    out, central = bytearray(), bytearray()
    for name, data, crc, size in entries:
        encoded = name.encode()
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, 8, 0, 0, crc,
                               len(data), size, len(encoded), 0, 0, 0, 0, 0, len(out))
        central += encoded
        out += struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, 8, 0, 0, crc, len(data),
                           size, len(encoded), 0) + encoded + data
    comment = b"tunnelsense-sha256:" + b"0" * 64
    start = len(out)
    out += central + struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(entries),
                                 len(entries), len(central), start, len(comment)) + comment
    out[-64:] = hashlib.sha256(bytes(out[:-64])).hexdigest().encode()
    return bytes(out)
