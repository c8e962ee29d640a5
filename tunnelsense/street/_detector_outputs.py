"""What :class:`~tunnelsense.street.ScanClusterer` returns: its online state and, run
over every run by the same state, the records, the scans' objects in view and the
object table.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.base import TransformerMixin

from tunnelsense._payload import (
    BEAMS,
    CLUSTERS,
    FINISHED_OBJECTS,
    IN_VIEW,
    OBJECTS,
    POINTS,
    SPEED,
    TILT,
)
from tunnelsense._records import RUN_LABELS, ScanSequence, check_scans
from tunnelsense._streaming import StreamingMixin
from tunnelsense.street._stream import ScanStream

__all__ = ["OBJECT_COLUMNS"]


#: Columns of the object table returned by :meth:`ScanClusterer.detect`.
OBJECT_COLUMNS = (
    "run",
    "id",
    "first_scan",
    "last_scan",
    "label",
    "mean_depth",
    "region",
    "length",
    "top_height",
    "n_points",
    "vehicle_class",
)


class _ScanClustererOutputs(StreamingMixin, TransformerMixin):
    """The outputs of :class:`~tunnelsense.street.ScanClusterer` (see there)."""

    _payload_reads = ()
    _payload_optional = (SPEED,)
    _payload_adds = (POINTS, BEAMS, CLUSTERS, OBJECTS, TILT, IN_VIEW, FINISHED_OBJECTS)

    # ------------------------------------------------------------ the method
    def start_stream(self):
        """An online state: scans in one at a time, finished records out.

        Batch :meth:`transform`, :meth:`predict` and :meth:`detect` run this very
        state over every run, so streaming and batch give identical results.

        Returns
        -------
        stream : ScanStream
            ``push(record) -> list`` of finished records (payload as
            :meth:`transform`), ``push_many(records)`` and ``close() -> list``.
            Every released record carries in its payload ``"finished_objects"``
            the object-table rows (:data:`OBJECT_COLUMNS`) that became final by
            then, in id order.  Memory follows the longest object in view, not the
            run's length.

        Examples
        --------
        >>> import numpy as np
        >>> from tunnelsense import LaserGeometry, ScanSequence
        >>> from tunnelsense.street import ScanClusterer
        >>> geom = LaserGeometry(np.deg2rad(-89.0), np.deg2rad(0.5), 0.05, 30.0, 2.0)
        >>> angles = geom.angles(181)
        >>> road = 2.0 / np.sin(-np.minimum(angles, -1e-3))
        >>> scans = np.tile(np.where(angles < 0, road, np.inf), (300, 1))
        >>> side = (angles > np.arctan(-1.8 / 5.0)) & (angles < np.arctan(-0.5 / 5.0))
        >>> scans[10:40, side] = 5.0 / np.cos(angles[side])   # a car side 5 m away
        >>> X = ScanSequence.from_arrays(scans, np.arange(300) / 75, geom, run="r")
        >>> stream = ScanClusterer(speed=11.1).fit(X).start_stream()
        >>> released = 0
        >>> for i, record in enumerate(X):
        ...     for done in stream.push(record):
        ...         released += 1
        ...         for row in done.payload["finished_objects"]:   # 4 m after its end
        ...             print(f"after scan {i}:", row[1:5], f"{released} scans out")
        after scan 67: (1, 10, 39, 'parked') 38 scans out
        >>> len(stream.close()) + released
        300
        """
        return super().start_stream()

    _sequence = ScanSequence
    _sort_tours = True  # ids count over the runs in the order of their names

    def _check_records(self, X):
        return check_scans(X)[0]

    def _stream_state(self, *, batch=False):
        return ScanStream(self)

    def _batch(self, X):
        """The records of ``X`` through the stream (input order) and the object table."""
        out, _ = self._stream_batch(X)
        rows = sorted((row for r in out for row in r.payload[FINISHED_OBJECTS]),
                      key=lambda row: row[1])
        table = pd.DataFrame(rows, columns=list(OBJECT_COLUMNS))
        table = table.astype({"id": np.int64, "first_scan": np.int64,
                              "last_scan": np.int64, "mean_depth": np.float64,
                              "region": np.int64, "length": np.float64,
                              "top_height": np.float64, "n_points": np.int64,
                              "run": object, "label": object,
                              "vehicle_class": object})
        return out, table

    # ------------------------------------------------------------- outputs
    def transform(self, X):  # the mixin's, documented with the payload
        """Per scan, the record with its clusters and objects in the payload.

        Parameters
        ----------
        X : sequence of ScanRecord

        Returns
        -------
        records : ScanSequence
            In the order of ``X``; payload ``"points"`` (n, 2) ROI ``(depth, height)``,
            ``"beams"`` (n,) their beam numbers, ``"clusters"`` (n,) intra-cluster
            number of every point, ``"objects"``
            (n_clusters,) object id (as in :meth:`detect`) of every intra-cluster,
            ``"tilt"`` the tilt (rad) used, ``"in_view"`` the ``(k, 2)`` array of
            :meth:`predict`, ``"finished_objects"`` the object-table rows that
            became final by the time the record was released (see
            :meth:`start_stream`).
        """
        return super().transform(X)

    def detect(self, X, *, all_objects=False):
        """The object table: one row per detected object.

        Parameters
        ----------
        X : sequence of ScanRecord
        all_objects : bool, default=False
            Keep objects of every label (``"roadside"``, ``"other"``); by default only
            those labelled with a key of :data:`~tunnelsense.RUN_LABELS`.

        Returns
        -------
        objects : DataFrame
            Columns :data:`OBJECT_COLUMNS`: ``run, id, first_scan, last_scan, label,
            mean_depth`` (m), ``region`` (1-3), ``length`` (m along the track),
            ``top_height`` (m), ``n_points``.  Ids count from 1 over the runs of ``X``
            in sorted order, by first scan (then mean depth) within a run.
        """
        table = self._batch(X)[1]
        if not all_objects:
            table = table[table["label"].isin(list(RUN_LABELS))].reset_index(drop=True)
        return table

    def predict(self, X):
        """Per scan, the ``(k, 2)`` array ``(object id, label code)`` of objects in view.

        The same layout as the targets ``y`` (:meth:`tunnelsense.Run.targets`), so that
        :mod:`tunnelsense.metrics` compares the two; only labels of
        :data:`~tunnelsense.RUN_LABELS` are reported.

        Parameters
        ----------
        X : sequence of ScanRecord

        Returns
        -------
        y_pred : list of ndarray of shape (k_i, 2), int64
        """
        return [r.payload["in_view"] for r in self._stream_batch(X)[0]]
