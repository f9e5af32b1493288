"""Errors the reconstruction service maps to HTTP statuses (the handler: services/recon/app.py)."""


class ReconServiceError(Exception):
    status_code = 400
    retry_after_s: int | None = None  # sent as Retry-After when set (busy / overloaded)

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class InvalidInput(ReconServiceError):
    status_code = 422


class PayloadTooLarge(ReconServiceError):
    status_code = 413


class SceneNotFound(ReconServiceError):
    status_code = 404


class BackboneUnavailable(ReconServiceError):
    status_code = 503


class BackboneNotInstalled(ReconServiceError):
    """The request names a backbone this installation cannot run (its weights are not present):
    the caller's choice conflicts with what is installed, and the message says what to run."""

    status_code = 409


class Overloaded(ReconServiceError):
    """Admission limits are full (queued reconstructions, images being decoded): retry later."""

    status_code = 503

    def __init__(self, message: str, retry_after_s: int) -> None:
        super().__init__(message)
        self.retry_after_s = retry_after_s


class LeaseWaitTimeout(ReconServiceError):
    """Another replica holds the reconstruction lease longer than this replica will wait."""

    status_code = 503

    def __init__(self, message: str, retry_after_s: int) -> None:
        super().__init__(message)
        self.retry_after_s = retry_after_s


class StorageFull(ReconServiceError):
    """The data dir (or the shared scene store) has no room left: 507 Insufficient Storage."""

    status_code = 507


class StorageUnavailable(ReconServiceError):
    """The data dir cannot be written or read (read-only, permissions, I/O error)."""

    status_code = 503
