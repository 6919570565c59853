"""Where a study runs: a Dask client for ``--dask ADDRESS`` / ``--workers N`` (:mod:`millstab.cluster`,
optional ``millstab[dask]``). Importing this imports no dask: :func:`open_client` yields None when neither
is given, and imports dask only when a client is asked for."""

from millstab.cluster import CONNECT_SECONDS, open_client

__all__ = ["CONNECT_SECONDS", "open_client"]
