"""Scene uploads: parsed within the byte, count and pixel limits, decoded off the event loop.

Order matters: the body is counted as it streams (chunked uploads too), file counts and sizes are
checked before any file is read into memory, image headers (sizes) are read before any image is
decoded, and decoding runs in worker processes one image at a time, keeping only the sizes.
"""

from __future__ import annotations

import asyncio
import io
import json
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass

import anyio
import numpy as np
from PIL import Image, UnidentifiedImageError
from pydantic import ValidationError
from starlette.datastructures import UploadFile
from starlette.formparsers import MultiPartException, MultiPartParser
from starlette.requests import Request

from services.recon.decode_worker import validate_image
from services.recon.errors import InvalidInput, Overloaded, PayloadTooLarge, ReconServiceError
from services.recon.lifetime import die_with_parent
from services.recon.offload import run_cpu
from services.recon.scene_store import SceneInput
from shared.imaging.codecs import ImageError, decode_base64, decode_image
from shared.wire.bodies import check_declared_length, limited_stream, read_body_limited
from shared.wire.schemas import SceneUpload
from shared.wire.settings import ReconSettings

MAX_CAMERA_FIELD_BYTES = 1 << 20  # a JSON list of 3x4 matrices for 256 views is ~40 KB

# The request body of `POST /v1/scenes` in OpenAPI: the route reads the raw request (streamed and
# counted here), so FastAPI cannot derive it from a parameter.
UPLOAD_OPENAPI = {
    "requestBody": {
        "required": True,
        "content": {
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "properties": {
                        "images": {"type": "array", "items": {"type": "string", "format": "binary"}},
                        "depths": {
                            "type": "array",
                            "items": {"type": "string", "format": "binary"},
                            "description": "optional float32 .npy z-depth per image",
                        },
                        "extrinsics": {"type": "string", "description": "optional JSON list of 3x4"},
                        "intrinsics": {
                            "type": "string",
                            "description": "optional JSON list of 3x3 (upright image pixels), null per "
                            "view for unknown cameras",
                        },
                    },
                    "required": ["images"],
                }
            },
            "application/json": {"schema": SceneUpload.model_json_schema()},
        },
    }
}


class PixelBudget:
    """Pixels being decoded right now across all uploads; a request that would exceed it waits
    for nobody: it gets 503 + Retry-After (memory is the resource, and a queue would hold it)."""

    def __init__(self, max_pixels: int) -> None:
        self.max_pixels = max_pixels
        self.in_use = 0

    def reserve(self, pixels: int) -> None:
        if self.in_use and self.in_use + pixels > self.max_pixels:
            raise Overloaded(
                f"{self.in_use} pixels are being decoded already (limit {self.max_pixels}); retry shortly",
                retry_after_s=2,
            )
        self.in_use += pixels

    def release(self, pixels: int) -> None:
        self.in_use -= pixels


@dataclass
class _RawScene:
    files: list[bytes]
    depth_files: list[bytes] | None
    extrinsics: object
    intrinsics: object


class SceneUploads:
    def __init__(self, settings: ReconSettings) -> None:
        self.settings = settings
        self.budget = PixelBudget(settings.max_decoding_pixels)
        self.decoders = anyio.CapacityLimiter(2)  # header-reading threads at once, across requests
        self._pool: ProcessPoolExecutor | None = None

    def _processes(self) -> ProcessPoolExecutor | None:
        """The decoding processes, started with the first upload (they import only Pillow/numpy)."""
        if self.settings.decode_processes and self._pool is None:
            self._pool = ProcessPoolExecutor(
                self.settings.decode_processes,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=die_with_parent,  # no orphans, even when the service is killed
                initargs=(os.getpid(),),
            )
        return self._pool

    def close(self, wait: bool = True) -> None:
        """Stop the decoding processes; `wait`: until they have exited (service shutdown)."""
        if self._pool is not None:
            self._pool.shutdown(wait=wait, cancel_futures=True)
            self._pool = None

    async def _validate(self, blob: bytes, index: int) -> tuple[int, int]:
        """Decode one image to prove it is whole, in a worker process when there are any: decoding
        holds the GIL long enough, in parts, to delay the event loop by tens of milliseconds."""
        arguments = (blob, index, self.settings.max_image_bytes, self.settings.max_image_pixels)
        pool = self._processes()
        if pool is None:
            size, failure = await run_cpu(validate_image, *arguments, limiter=self.decoders)
            _raise_image_error(failure)
            return size
        loop = asyncio.get_running_loop()
        try:
            size, failure = await loop.run_in_executor(pool, validate_image, *arguments)
        except BrokenProcessPool as error:  # a worker died (e.g. killed for memory): start afresh
            self.close(wait=False)
            raise DecoderFailed(f"the image decoder process failed on image {index + 1}; retry") from error
        _raise_image_error(failure)
        return size

    async def read(self, request: Request) -> SceneInput:
        check_declared_length(request, self.settings.max_request_bytes)
        content_type = request.headers.get("content-type", "")
        if content_type.startswith("multipart/form-data"):
            raw = await self._read_multipart(request)
        elif content_type.startswith("application/json"):
            raw = await self._read_json(request)
        else:
            raise InvalidInput(
                "send the images as multipart/form-data (field 'images') or JSON {\"images\": [base64,...]}"
            )
        return await self._decode(raw)

    # ---- parsing -----------------------------------------------------------------------------

    async def _read_multipart(self, request: Request) -> _RawScene:
        limit = self.settings.max_images
        parser = MultiPartParser(
            request.headers,
            limited_stream(request, self.settings.max_request_bytes),
            max_files=2 * limit,  # images and depths
            max_fields=8,
            max_part_size=MAX_CAMERA_FIELD_BYTES,
        )
        try:
            form = await parser.parse()
        except MultiPartException as error:
            raise InvalidInput(f"could not parse the multipart upload: {error.message}") from error
        try:
            images = form.getlist("images")
            depths = form.getlist("depths")
            for name, items in (("images", images), ("depths", depths)):
                if len(items) > limit:  # before any file is read into memory
                    raise InvalidInput(f"{len(items)} {name}; a scene has at most {limit} images")
                for item in items:
                    if not isinstance(item, UploadFile):
                        raise InvalidInput(f"field '{name}' must carry files")
                    if item.size is not None and item.size > self.settings.max_image_bytes:
                        raise PayloadTooLarge(
                            f"{item.filename} is {item.size} bytes; "
                            f"the limit is {self.settings.max_image_bytes}"
                        )
            files = [await item.read() for item in images]
            depth_files = [await item.read() for item in depths] or None
            cameras = {}
            for name in ("extrinsics", "intrinsics"):
                raw = form.get(name)
                if raw is not None:
                    text = raw if isinstance(raw, str) else await raw.read(MAX_CAMERA_FIELD_BYTES + 1)
                    cameras[name] = await run_cpu(_parse_camera_json, name, text)
        finally:
            await form.close()
        return _RawScene(files, depth_files, cameras.get("extrinsics"), cameras.get("intrinsics"))

    async def _read_json(self, request: Request) -> _RawScene:
        body = await read_body_limited(request, self.settings.max_request_bytes)
        upload = await run_cpu(_parse_json_upload, body)
        if len(upload.images) > self.settings.max_images:
            raise InvalidInput(f"{len(upload.images)} images; a scene has at most {self.settings.max_images}")

        def decode_all() -> _RawScene:
            files = [decode_base64(text, f"image {i + 1}") for i, text in enumerate(upload.images)]
            depths = None
            if upload.depths is not None:
                depths = [decode_base64(t, f"depth {i}") for i, t in enumerate(upload.depths)]
            return _RawScene(files, depths, upload.extrinsics, upload.intrinsics)

        return await run_cpu(decode_all)

    # ---- validation and decoding ------------------------------------------------------------

    async def _decode(self, raw: _RawScene) -> SceneInput:
        limit = self.settings.max_images
        if not raw.files:
            raise InvalidInput(f"no images: send 1 to {limit} images in the field 'images'")
        if len(raw.files) > limit:
            raise InvalidInput(f"{len(raw.files)} images; a scene has at most {limit}")
        sizes = await run_cpu(self._header_sizes, raw.files, limiter=self.decoders)
        pixels = sum(width * height for width, height in sizes)
        if pixels > self.settings.max_request_pixels:
            raise PayloadTooLarge(
                f"the images hold {pixels} pixels in all; "
                f"one upload may hold {self.settings.max_request_pixels}"
            )
        self.budget.reserve(pixels)
        try:
            for index, blob in enumerate(raw.files):  # one at a time: only one decoded image in memory
                sizes[index] = await self._validate(blob, index)  # upright (EXIF orientation)
        finally:
            self.budget.release(pixels)
        scene = SceneInput(image_files=raw.files, sizes=sizes)
        if raw.depth_files is not None:
            scene.depths = await run_cpu(
                lambda: [_load_npy(data, f"depth {i}") for i, data in enumerate(raw.depth_files)]
            )
        intrinsics = raw.intrinsics
        if isinstance(intrinsics, list):  # null for a view whose camera is unknown
            intrinsics = [np.full((3, 3), np.nan) if matrix is None else matrix for matrix in intrinsics]
        for name, value in (("extrinsics", raw.extrinsics), ("intrinsics", intrinsics)):
            if value is not None:
                try:
                    setattr(scene, name, np.asarray(value, dtype=np.float64))
                except (TypeError, ValueError, RecursionError) as error:
                    raise InvalidInput(f"{name} must be a list of numeric matrices: {error}") from error
        return scene

    def _header_sizes(self, files: list[bytes]) -> list[tuple[int, int]]:
        """(width, height) from each file's header, without decoding the pixels."""
        sizes = []
        for index, blob in enumerate(files):
            label = f"image {index + 1}"
            if not blob:
                raise ImageError(f"{label} is empty")
            if len(blob) > self.settings.max_image_bytes:
                raise ImageError(
                    f"{label} is {len(blob)} bytes; the limit is {self.settings.max_image_bytes}",
                    over_limit=True,
                )
            try:
                with Image.open(io.BytesIO(blob)) as probe:
                    width, height = probe.size
            except (UnidentifiedImageError, OSError, SyntaxError, ValueError, Image.DecompressionBombError):
                # unreadable: decode_image fails at once too, with the reason it gives everywhere
                decode_image(
                    blob,
                    max_bytes=self.settings.max_image_bytes,
                    max_pixels=self.settings.max_image_pixels,
                    label=label,
                )
                raise ImageError(f"{label} is not an image file this service can read") from None
            if width * height > self.settings.max_image_pixels:
                raise ImageError(
                    f"{label} is {width}x{height} pixels; "
                    f"the limit is {self.settings.max_image_pixels} pixels",
                    over_limit=True,
                )
            sizes.append((width, height))
        return sizes


class DecoderFailed(ReconServiceError):
    status_code = 503


def _raise_image_error(failure: tuple[str, bool] | None) -> None:
    if failure is not None:
        raise ImageError(failure[0], over_limit=failure[1])


def _parse_json_upload(body: bytes) -> SceneUpload:
    try:
        return SceneUpload.model_validate_json(body)
    except ValidationError as error:
        first = error.errors()[0]
        location = ".".join(str(part) for part in first["loc"])
        message = f"{location}: {first['msg']}" if location else first["msg"]
        raise InvalidInput(f"invalid scene upload: {message}") from error


def _parse_camera_json(name: str, text: str | bytes):
    if len(text) > MAX_CAMERA_FIELD_BYTES:
        raise PayloadTooLarge(f"{name} is over {MAX_CAMERA_FIELD_BYTES} bytes")
    try:
        return json.loads(text)
    except RecursionError as error:
        raise InvalidInput(f"{name} is nested too deeply: send a list of matrices") from error
    except ValueError as error:
        raise InvalidInput(f"{name} must be JSON: {error}") from error


def _load_npy(data: bytes, label: str) -> np.ndarray:
    try:
        array = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError) as error:
        raise InvalidInput(f"{label} is not a .npy array: {error}") from error
    if not isinstance(array, np.ndarray):  # an .npz archive loads as a dict-like NpzFile
        raise InvalidInput(f"{label} is not a .npy array (an .npz archive or another format was sent)")
    if not np.issubdtype(array.dtype, np.number):
        raise InvalidInput(f"{label} must be numeric, got {array.dtype}")
    return array.astype(np.float32)
