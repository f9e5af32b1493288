"""Errors the reconstruction service maps to HTTP statuses (see app.py)."""


class ReconServiceError(Exception):
    status_code = 400

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
