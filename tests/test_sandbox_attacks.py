"""Attack corpus: programs that try to escape the sandbox or exhaust the machine.

Each attack states how it must end: the error kind (rejected by the validator, stopped by a limit,
failed inside the program, refused as output) and a fragment of the error message naming the
reason. Nothing may end with ok=True, except the protocol-forging attempt, whose forged line must
come back as plain captured stdout while the real result stays intact.
"""

from __future__ import annotations

import io
import json
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import pytest
from PIL import Image

from services.agent.sandbox import SandboxLimits, run_program
from services.agent.sandbox.builtins import OutputCapture, program_globals
from services.agent.sandbox.jail import JailMode, JailStatus
from services.agent.sandbox.validation import (
    ATTRIBUTE_FUNCTION_NAME,
    IN_PLACE_ITEM_FUNCTION_NAME,
    RESULT_FUNCTION_NAME,
)
from services.agent.sandbox.worker_process import REPO_ROOT

# The agent's own output, image and tool-call limits, so that the corpus ends the same way through
# the runner and through /v1/solve (tests/test_sandbox_http.py sets the same CPU, wall and memory).
LIMITS = SandboxLimits(cpu_seconds=5, wall_seconds=5, memory_mb=512)


class TinyTools:
    """A real provider with two level cameras and 16x16 PNGs: enough for attacks that use tools."""

    def __init__(self) -> None:
        self.calls: list[str] = []

    def _png(self, value: int) -> bytes:
        buffer = io.BytesIO()
        Image.fromarray(np.full((16, 16, 3), value, dtype=np.uint8)).save(buffer, format="PNG")
        return buffer.getvalue()

    def reconstruct(self) -> dict:
        self.calls.append("reconstruct")
        poses = [np.hstack([np.eye(3), [[x], [0.0], [0.0]]]) for x in (0.0, -0.5)]
        return {
            "extrinsics": [pose.tolist() for pose in poses],
            "intrinsics": [[[16.0, 0, 8], [0, 16.0, 8], [0, 0, 1]]] * 2,
            "image_sizes": [[16, 16]] * 2,
            "registered": [True, True],
        }

    def describe_camera_motion(self) -> list[str]:
        self.calls.append("describe_camera_motion")
        return ["From image 1 to image 2 the camera moved right by 0.50."]

    def synthesize_novel_view(self, extrinsic: list[list[float]], width: int, height: int) -> bytes:
        self.calls.append("synthesize_novel_view")
        return self._png(int(abs(np.asarray(extrinsic)[0, 3]) * 100) % 256)

    def input_image(self, index: int) -> bytes:
        self.calls.append("input_image")
        return self._png(40 * index)


@dataclass(frozen=True)
class Attack:
    name: str
    body: str  # the program; `def program(input_scene):` is added when the body is indented code
    kind: str
    reason: str  # a fragment the error message must contain (for "ok": the exact clue text)
    stdout: str | None = None  # for "ok": what the program printed, exactly (checked by the runner)

    @property
    def source(self) -> str:
        if self.body.startswith("    "):
            return "def program(input_scene):\n" + self.body
        return self.body


def wrap(*lines: str) -> str:
    return "".join(f"    {line}\n" for line in lines)


R = "rejected"
ATTACKS = [
    # --- imports in every spelling --------------------------------------------------------
    Attack("import_os", wrap("import os", "return os.listdir('/')"), R, "imports are not allowed"),
    Attack("from_import", wrap("from os import system", "return system('id')"), R, "imports are not allowed"),
    Attack("import_alias", wrap("import numpy as os", "return 1"), R, "imports are not allowed"),
    Attack("import_submodule", wrap("import numpy.ctypeslib", "return 1"), R, "imports are not allowed"),
    Attack(
        "top_level_import", "import subprocess\ndef program(input_scene):\n    return 1\n", R, "imports are"
    ),
    Attack("dunder_import", wrap("return __import__('os').getcwd()"), R, "'__import__' is not allowed"),
    Attack(
        "builtins_dict", wrap("return __builtins__['__import__']('os')"), R, "'__builtins__' is not allowed"
    ),
    Attack("getattr_builtins", wrap("return getattr(__builtins__, 'open')"), R, "'getattr' is not available"),
    Attack("importlib", wrap("return importlib.import_module('os')"), R, "'importlib' is not available"),
    Attack("name_sys", wrap("return sys.version"), "exception", "NameError: name 'sys' is not defined"),
    # --- class hierarchy walks -----------------------------------------------------------
    Attack(
        "subclasses",
        wrap("return ().__class__.__bases__[0].__subclasses__()"),
        R,
        "'.__class__' is not allowed",
    ),
    Attack("type_mro", wrap("return type(input_scene).mro()"), R, "'type' is not available"),
    Attack("list_mro", wrap("return [].mro()"), R, "'.mro' is not available"),
    Attack("object_base", wrap("return object"), R, "'object' is not available"),
    Attack("scene_dict", wrap("return input_scene.__dict__"), R, "'.__dict__' is not allowed"),
    Attack("api_channel", wrap("return pySpatial._channel"), R, "'._channel' is not allowed"),
    Attack("fstring_dunder", wrap("return f'{input_scene.__class__}'"), R, "'.__class__' is not allowed"),
    Attack("vars_scene", wrap("return vars(input_scene)"), R, "'vars' is not available"),
    Attack("globals_call", wrap("return globals()"), R, "'globals' is not available"),
    # --- frames, generators, tracebacks --------------------------------------------------
    Attack(
        "generator_frame",
        wrap("g = (i for i in range(3))", "return g.gi_frame.f_back.f_globals"),
        R,
        "'.gi_frame' is not allowed",
    ),
    Attack(
        "traceback_frame",
        wrap(
            "try:",
            "    1 / 0",
            "except Exception as e:",
            "    tb = e.with_traceback(None)",
            "    return tb.tb_frame",
        ),
        R,
        "'.tb_frame' is not allowed",
    ),
    Attack("frame_back", wrap("f = None", "return f.f_back"), R, "'.f_back' is not allowed"),
    Attack("code_object", wrap("return program.co_consts"), R, "'.co_consts' is not allowed"),
    Attack("yield_generator", wrap("yield 1"), R, "'yield' is not allowed"),
    # --- format-string attribute access ---------------------------------------------------
    Attack(
        "format_class",
        wrap("return '{0.__class__}'.format(input_scene)"),
        "exception",
        "format field '{0.__class__}' is not allowed",
    ),
    Attack(
        "format_index",
        wrap("return '{0[0]}'.format(input_scene.images)"),
        "exception",
        "format field '{0[0]}' is not allowed",
    ),
    Attack(
        "str_format_unbound",
        wrap("return str.format('{0.images}', input_scene)"),
        "exception",
        "format field '{0.images}' is not allowed",
    ),
    Attack("format_map", wrap("return '{x.images}'.format_map({'x': input_scene})"), R, "'.format_map'"),
    Attack(
        "format_reference",
        wrap("f = '{0.__class__}'.format", "return f(1)"),
        R,
        "'.format' may only be called",
    ),
    # --- numpy file and memory access -----------------------------------------------------
    Attack("np_load", wrap("return np.load('/etc/passwd')"), R, "'.load' is not available"),
    Attack("np_save", wrap("np.save('x.npy', np.zeros(3))", "return 1"), R, "'.save' is not available"),
    Attack("np_fromfile", wrap("return np.fromfile('/etc/passwd')"), R, "'.fromfile' is not available"),
    Attack("np_memmap", wrap("return np.memmap('/etc/passwd')"), R, "'.memmap' is not available"),
    Attack("arr_tofile", wrap("np.zeros(3).tofile('x')", "return 1"), R, "'.tofile' is not available"),
    Attack("np_lib", wrap("return np.lib.format"), R, "'.lib' is not available"),
    Attack("np_ctypeslib", wrap("return np.ctypeslib"), R, "'.ctypeslib' is not available"),
    Attack("arr_ctypes", wrap("return np.zeros(3).ctypes"), R, "'.ctypes' is not available"),
    Attack("np_random", wrap("return np.random.rand(3)"), "exception", "np.random is not available"),
    # --- dangerous builtins ---------------------------------------------------------------
    Attack("open_file", wrap("return open('/etc/passwd').read()"), R, "'open' is not available"),
    Attack("exec_code", wrap("exec('import os')", "return 1"), R, "'exec' is not available"),
    Attack("eval_code", wrap("return eval('1')"), R, "'eval' is not available"),
    Attack("compile_code", wrap("return compile('1', 'x', 'eval')"), R, "'compile' is not available"),
    Attack("breakpoint_call", wrap("breakpoint()", "return 1"), R, "'breakpoint' is not available"),
    Attack(
        "print_to_file",
        wrap("import math", "print('x', file=math)", "return 1"),
        "exception",
        "TypeError: print(file=...) is not available in the sandbox (line 3)",
    ),
    # --- writes to the API ----------------------------------------------------------------
    Attack(
        "attribute_write",
        wrap("input_scene.question = 'x'", "return 1"),
        R,
        "assigning or deleting attributes",
    ),
    Attack(
        "attribute_delete",
        wrap("del pySpatial.reconstruct", "return 1"),
        R,
        "assigning or deleting attributes",
    ),
    Attack("np_patch", wrap("np.linalg = None", "return 1"), R, "assigning or deleting attributes"),
    # --- program shape --------------------------------------------------------------------
    Attack(
        "missing_program", "def solve(input_scene):\n    return 1\n", R, "must define a top-level function"
    ),
    Attack("empty", "   \n", R, "the program is empty"),
    Attack(
        "two_programs",
        "def program(input_scene):\n    return 1\ndef program(input_scene):\n    return 2\n",
        R,
        "defined 2 times",
    ),
    Attack("no_argument", "def program():\n    return 1\n", R, "must take exactly one argument"),
    Attack(
        "class_def",
        "class Evil:\n    pass\ndef program(input_scene):\n    return 1\n",
        R,
        "class definitions",
    ),
    Attack("top_level_code", "x = open('f')\ndef program(input_scene):\n    return 1\n", R, "top level"),
    Attack("global_statement", wrap("global np", "np = None", "return 1"), R, "'global' is not allowed"),
    Attack("async_def", "async def program(input_scene):\n    return 1\n", R, "async functions"),
    Attack("decorated", "@staticmethod\ndef program(input_scene):\n    return 1\n", R, "decorators"),
    Attack("with_statement", wrap("with input_scene:", "    return 1"), R, "'with' statements"),
    Attack("syntax_error", "def program(input_scene) return 1\n", R, "syntax error at line 1"),
    Attack("too_long", "def program(input_scene):\n" + "    x = 1\n" * 4000, R, "the limit is 20000"),
    Attack("deep_sum", wrap("return " + "+".join(["1"] * 9000)), R, "nested too deeply to parse"),
    Attack("deep_unary", wrap("return " + "-" * 15000 + "1"), R, "nested too deeply to parse"),
    Attack("deep_parentheses", wrap("return " + "(" * 300 + ")" * 300), R, "too many nested parentheses"),
    Attack("nul_byte", "def program(input_scene):\n    return '\x00'\n", R, "NUL character"),
    # --- resource exhaustion --------------------------------------------------------------
    Attack("list_bomb", wrap("return [0] * 10**10"), "memory", "memory limit exceeded"),
    Attack("string_bomb", wrap("return 'a' * 10**12"), "memory", "memory limit exceeded"),
    Attack("numpy_bomb", wrap("return np.zeros((10**6, 10**6))"), "memory", "memory limit exceeded"),
    Attack(
        "growing_bomb",
        wrap("chunks = []", "while True:", "    chunks.append('a' * 10**7)"),
        "memory",
        "memory limit exceeded",
    ),
    Attack(
        "recursion_bomb",
        "def dive(n):\n    return dive(n + 1)\ndef program(input_scene):\n    return dive(0)\n",
        "exception",
        "RecursionError: maximum recursion depth exceeded",
    ),
    Attack("huge_range", wrap("return sum(range(10**12))"), "exception", "range of more than 10000000 items"),
    # --- outputs --------------------------------------------------------------------------
    Attack(
        "huge_string",
        wrap("return 'a' * 10**6"),
        "output",
        "output too large: the output is 1000000 characters",
    ),
    Attack(
        "huge_list",
        wrap("return list(range(10**6))"),
        "output",
        "output too large: the return value has more",
    ),
    Attack(
        "huge_array", wrap("return np.ones((200, 200))"), "output", "output too large: a returned numpy array"
    ),
    Attack(
        "huge_print",
        wrap("while True:", "    print('x' * 1000)"),
        "output",
        "printed more than 20000 characters",
    ),
    Attack(
        "caught_huge_print",
        wrap("try:", "    print('x' * 50000)", "except Exception:", "    pass", "return 'fine'"),
        "output",
        "printed more than 20000 characters",
    ),
    Attack(
        "return_function",
        "def helper():\n    return 1\ndef program(input_scene):\n    return helper\n",
        "output",
        "output is not serializable: a value of type function",
    ),
    Attack("return_set", wrap("return {input_scene}"), "output", "returned a set; return a list instead"),
    Attack("return_generator", wrap("return (i for i in range(3))"), "output", "type generator"),
    Attack("return_scene", wrap("return input_scene"), "output", "type Scene cannot be returned"),
    Attack("return_api", wrap("return [pySpatial]"), "output", "type PySpatial cannot be returned"),
    Attack("deep_nesting", wrap("return [[[[1]]]]"), "output", "nested more than 3 levels"),
    Attack(
        "object_array",
        wrap("return np.array([input_scene])"),
        "exception",
        "np.array would make a numpy array of dtype object",
    ),
    # --- tool abuse -----------------------------------------------------------------------
    Attack(
        "render_too_big",
        wrap(
            "r = pySpatial.reconstruct(input_scene)",
            "return pySpatial.synthesize_novel_view(r, r.extrinsics[0], 10**5)",
        ),
        "exception",
        "width must be an integer from 16 to 2048",
    ),
    Attack(
        "render_garbage_pose",
        wrap(
            "r = pySpatial.reconstruct(input_scene)",
            "return pySpatial.synthesize_novel_view(r, [[1, 2], [3, 4]])",
        ),
        "exception",
        "extrinsic must be 3x4 or 4x4",
    ),
    Attack(
        "reconstruct_other",
        wrap("return pySpatial.reconstruct(['/etc/passwd'])"),
        "exception",
        "reconstruct(scene) takes the input_scene",
    ),
]


E, OUT, OK = "exception", "output", "ok"
NDARRAY = "TypeError: np.ndarray(...) is not available in the sandbox; use np.array, np.zeros or np.ones"
OBJECT_DTYPE = "TypeError: numpy arrays of dtype object are not available in the sandbox"
HIDDEN = "<function program.<locals>.f at (address hidden)>"
F = "    def f():\n        return 1\n"
MEMORY_ATTACKS = [
    # --- raw memory through numpy: buffers, strides, offsets, object dtypes ---------------
    Attack(
        "ndarray_buffer_object", wrap("return np.ndarray((1,), buffer=b'x' * 8, dtype=float)"), E, NDARRAY
    ),
    Attack("ndarray_strides", wrap("return np.ndarray((4,), strides=(0,))"), E, NDARRAY),
    Attack("ndarray_offset", wrap("return np.ndarray((1,), buffer=b'x' * 64, offset=56)"), E, NDARRAY),
    Attack("ndarray_positional", wrap("return np.ndarray((2,), float, b'x' * 16, 0, (8,))"), E, NDARRAY),
    Attack("ndarray_object", wrap("return np.ndarray((1,), dtype=int)"), E, NDARRAY),
    Attack(
        "ndarray_attribute",
        wrap("return np.ndarray.copy"),
        E,
        "AttributeError: np.ndarray.copy is not available in the sandbox",
    ),
    Attack(
        "ndarray_dunder_new",
        wrap("return np.ndarray.__new__(np.ndarray, (1,))"),
        R,
        "'.__new__' is not allowed",
    ),
    Attack(
        "array_dtype_object", wrap("return np.array([1, 2], dtype=object)"), R, "'object' is not available"
    ),
    Attack("array_dtype_O", wrap("return np.array([1, 2], dtype='O')"), E, OBJECT_DTYPE),
    Attack("array_dtype_positional", wrap("return np.array([1, 2], 'O')"), E, OBJECT_DTYPE),
    Attack("zeros_object", wrap("return np.zeros(3, dtype='O')"), E, OBJECT_DTYPE),
    Attack("ones_object", wrap("return np.ones(3, 'O')"), E, OBJECT_DTYPE),
    Attack(
        "asarray_scene",
        wrap("return np.asarray([input_scene, 1])"),
        E,
        "TypeError: np.asarray would make a numpy array of dtype object",
    ),
    Attack(
        "stack_api",
        wrap("return np.stack([[pySpatial], [pySpatial]])"),
        E,
        "TypeError: np.stack would make a numpy array of dtype object",
    ),
    Attack(
        "where_object",
        wrap("return np.where([True], [input_scene], [0])"),
        E,
        "TypeError: np.where would make a numpy array of dtype object",
    ),
    Attack(
        "concatenate_object",
        wrap("return np.concatenate([[input_scene], [1]])"),
        E,
        "TypeError: np.concatenate would make a numpy array of dtype object",
    ),
    Attack(
        "void_dtype",
        wrap("return np.zeros(2, dtype='V8')"),
        E,
        "TypeError: numpy arrays of dtype |V8 are not available in the sandbox",
    ),
    Attack(
        "datetime_dtype",
        wrap("return np.zeros(2, dtype='M8[s]')"),
        E,
        "TypeError: numpy arrays of dtype datetime64[s] are not available in the sandbox",
    ),
    Attack(
        "np_empty", wrap("return np.empty(3)"), E, "AttributeError: np.empty is not available in the sandbox"
    ),
    Attack(
        "np_dtype",
        wrap("return np.dtype('O')"),
        E,
        "AttributeError: np.dtype is not available in the sandbox",
    ),
    Attack("np_frombuffer", wrap("return np.frombuffer(bytearray(8))"), R, "'.frombuffer' is not available"),
    Attack(
        "np_fromstring", wrap("return np.fromstring('1 2', sep=' ')"), R, "'.fromstring' is not available"
    ),
    Attack(
        "np_stride_tricks",
        wrap("return np.lib.stride_tricks.as_strided(np.zeros(1), (9,), (0,))"),
        R,
        "'.lib' is not available",
    ),
    Attack(
        "np_as_strided",
        wrap("return np.as_strided"),
        E,
        "AttributeError: np.as_strided is not available in the sandbox",
    ),
    Attack("array_view", wrap("return np.zeros(2).view('O')"), R, "'.view' is not available"),
    Attack("array_tobytes", wrap("return np.zeros(2).tobytes()"), R, "'.tobytes' is not available"),
    Attack("array_tostring", wrap("return np.zeros(2).tostring()"), R, "'.tostring' is not available"),
    Attack("array_getfield", wrap("return np.zeros(2).getfield('O', 0)"), R, "'.getfield' is not available"),
    Attack(
        "array_setfield",
        wrap("a = np.zeros(2)", "a.setfield(1, 'O', 0)", "return 1"),
        R,
        "'.setfield' is not available",
    ),
    Attack(
        "array_itemset",
        wrap("a = np.zeros(2)", "a.itemset(0, 1)", "return 1"),
        R,
        "'.itemset' is not available",
    ),
    Attack("array_data", wrap("return np.zeros(2).data"), R, "'.data' is not available"),
    Attack("array_base", wrap("return np.zeros(4)[1:].base"), R, "'.base' is not available"),
    Attack(
        "array_strides_write",
        wrap("a = np.zeros(2)", "a.strides = (0,)", "return 1"),
        R,
        "assigning or deleting attributes",
    ),
    Attack(
        "array_interface",
        wrap("return np.zeros(2).__array_interface__"),
        R,
        "'.__array_interface__' is not allowed",
    ),
    Attack("array_ctypes_data", wrap("return np.zeros(2).ctypes.data"), R, "'.ctypes' is not available"),
    Attack(
        "array_setflags",
        wrap("a = np.zeros(2)", "a.setflags(write=True)", "return 1"),
        R,
        "'.setflags' is not available",
    ),
    Attack(
        "array_newbyteorder", wrap("return np.zeros(2).newbyteorder()"), R, "'.newbyteorder' is not available"
    ),
    Attack(
        "astype_void_returned",
        wrap("return np.zeros(2).astype('V8')"),
        E,
        "TypeError: astype(|V8) is not available in the sandbox: arrays convert only to numeric dtypes",
    ),
    Attack("memoryview_name", wrap("return memoryview(bytearray(8))"), R, "'memoryview' is not available"),
    Attack("bytearray_name", wrap("return bytearray(8)"), E, "NameError: name 'bytearray' is not defined"),
    Attack(
        "linalg_lapack",
        wrap("return np.linalg.lapack_lite"),
        E,
        "AttributeError: np.linalg.lapack_lite is not available in the sandbox",
    ),
    Attack("str_stand_in_dunder", wrap("return str.__base__"), R, "'.__base__' is not allowed"),
    Attack(
        "str_stand_in_unknown",
        wrap("return str.maketrans_unknown"),
        E,
        "AttributeError: str.maketrans_unknown is not available in the sandbox",
    ),
    # --- heap addresses never reach a program's text ---------------------------------------
    Attack("address_repr", F + wrap("return repr(f)"), OK, HIDDEN),
    Attack("address_str", F + wrap("return str(f)"), OK, HIDDEN),
    Attack("address_fstring", F + wrap("return f'{f}'"), OK, HIDDEN),
    Attack("address_fstring_repr", F + wrap("return f'{f!r}'"), OK, HIDDEN),
    Attack("address_percent", F + wrap("return '%s' % f"), OK, HIDDEN),
    Attack("address_percent_assign", F + wrap("text = '%r'", "text %= (f,)", "return text"), OK, HIDDEN),
    Attack("address_format_method", F + wrap("return '{}'.format(f)"), OK, HIDDEN),
    Attack("address_format_builtin", F + wrap("return format(f)"), OK, HIDDEN),
    Attack("address_ascii", F + wrap("return ascii(f)"), OK, HIDDEN),
    Attack("address_in_list", F + wrap("return str([f])"), OK, f"[{HIDDEN}]"),
    Attack("address_in_dict", F + wrap("return repr({'k': f})"), OK, f"{{'k': {HIDDEN}}}"),
    Attack("address_print", F + wrap("print(f)", "return 1 + 1"), OK, "2", stdout=HIDDEN + "\n"),
    Attack(
        "address_lambda",
        wrap("return repr(lambda: 1)"),
        OK,
        "<function program.<locals>.<lambda> at (address hidden)>",
    ),
    Attack(
        "address_generator",
        wrap("return str(i for i in range(1))"),
        OK,
        "<generator object program.<locals>.<genexpr> at (address hidden)>",
    ),
    Attack(
        "address_builtin",
        wrap("return repr(len) + str(print)[:22]"),
        OK,
        "<built-in function len><function make_print.<",
    ),
    Attack(
        "address_in_error",
        F + wrap("return {}[f]"),
        E,
        "program raised KeyError: <function program.<locals>.f at (address hidden)> (line 4)",
    ),
    Attack("address_id", wrap("return id(input_scene)"), R, "'id' is not available"),
    Attack("address_hash", wrap("return hash(input_scene)"), E, "NameError: name 'hash' is not defined"),
    Attack(
        "address_object_array_bytes",
        wrap("return np.array([input_scene]).tobytes()"),
        R,
        "'.tobytes' is not available",
    ),
    # --- processes, sessions, the parent: names the program never has ----------------------
    Attack("fork_name", wrap("return os.fork()"), E, "NameError: name 'os' is not defined"),
    Attack("setsid_name", wrap("return os.setsid()"), E, "NameError: name 'os' is not defined"),
    Attack("kill_parent", wrap("return os.kill(os.getppid(), 9)"), E, "NameError: name 'os' is not defined"),
    Attack("fork_via_import", wrap("import os", "return os.fork()"), R, "imports are not allowed"),
    Attack(
        "subprocess_import",
        wrap("import subprocess", "return subprocess.run(['id'])"),
        R,
        "imports are not allowed",
    ),
    Attack("socket_import", wrap("import socket", "return socket.socket()"), R, "imports are not allowed"),
    Attack(
        "from_math_private",
        "from math import __loader__\ndef program(input_scene):\n    return 1\n",
        R,
        "'__loader__' is not allowed",
    ),
    Attack(
        "from_os_import",
        "from os import fork\ndef program(input_scene):\n    return fork()\n",
        R,
        "imports are not allowed",
    ),
    Attack(
        "from_math_star",
        "from math import *\ndef program(input_scene):\n    return 1\n",
        R,
        "'from math import *' is not allowed",
    ),
    Attack(
        "from_numpy_hidden",
        "from numpy import frombuffer\ndef program(input_scene):\n    return frombuffer\n",
        E,
        "AttributeError: np.frombuffer is not available in the sandbox",
    ),
    Attack(
        "relative_import",
        "from . import math\ndef program(input_scene):\n    return 1\n",
        R,
        "imports are not allowed",
    ),
    Attack(
        "hasattr_private",
        wrap("return [hasattr(input_scene, '__class__'), hasattr(input_scene, 'gi_frame')]"),
        OK,
        "False\nFalse",
    ),
    Attack(
        "hasattr_non_string",
        wrap("return hasattr(input_scene, 1)"),
        E,
        "TypeError: hasattr(): attribute name must be a string",
    ),
    # --- text that cannot be encoded ---------------------------------------------------------
    Attack("surrogate_return", wrap("return 'a\\ud800b'"), OK, "a\ufffdb"),
    Attack("surrogate_in_list", wrap("return ['\\udfff', 'ok']"), OK, "\ufffd\nok"),
    Attack("surrogate_dict_key", wrap("return {'\\ud83d': 1}"), OK, "\ufffd: 1"),
    Attack("surrogate_nested", wrap("return [['\\ud800']]"), OK, '["\ufffd"]'),
    Attack(
        "surrogate_error",
        wrap("raise ValueError('bad \\ud800 text')"),
        E,
        "program raised ValueError: bad \ufffd text (line 2)",
    ),
    Attack(
        "surrogate_key_error", wrap("return {}['\\udc80']"), E, "program raised KeyError: '\\udc80' (line 2)"
    ),
    Attack(
        "surrogate_in_source",
        wrap("return 'x\ud800'"),
        R,
        "rejected: the program cannot be parsed: 'utf-8' codec can't encode character '\\ud800' in "
        "position 39: surrogates not allowed",
    ),
    Attack("surrogate_print", wrap("print('\\ud800')", "return 1 + 2"), OK, "3", stdout="\ufffd\n"),
    Attack("surrogate_chr", wrap("return chr(0xDFFF) + chr(0xD800)"), OK, "\ufffd\ufffd"),
    # --- honest compile errors ---------------------------------------------------------------
    Attack("break_outside_loop", wrap("break"), R, "rejected: syntax error at line 2: 'break' outside loop"),
    Attack(
        "continue_outside_loop",
        wrap("continue"),
        R,
        "rejected: syntax error at line 2: 'continue' not properly in loop",
    ),
    Attack(
        "return_outside_function",
        "def program(input_scene):\n    return 1\nif True:\n    return 2\n",
        R,
        "top level",
    ),
    Attack(
        "nonlocal_missing",
        "def program(input_scene):\n    def inner():\n        nonlocal missing\n    return 1\n",
        R,
        "'nonlocal' is not allowed",
    ),
    Attack(
        "duplicate_argument",
        wrap("def g(a, a):", "    return 1", "return 1"),
        R,
        "rejected: syntax error at line 2: duplicate argument 'a' in function definition",
    ),
    Attack(
        "too_many_blocks",
        wrap(*["    " * i + f"for i{i} in range(1):" for i in range(21)], "    " * 21 + "pass", "return 1"),
        R,
        "rejected: syntax error at line 22: too many statically nested blocks",
    ),
]

ATTACKS += MEMORY_ATTACKS


# --- the numpy allow-list: memory corruption, in-place and raw-memory routes, by every path -------
def refused(label: str, name: str) -> str:
    return f"AttributeError: {label}.{name} is not available in the sandbox"


A, S = "array", "numpy scalar"
VIEW = wrap("a = np.zeros(4)", "v = a[1:]")
NUMPY_SURFACE_ATTACKS = [
    # use-after-free: resize frees the buffer a view still points at
    Attack(
        "resize_refcheck",
        VIEW + wrap("a.resize((1 << 20,), refcheck=False)", "return v[0]"),
        E,
        refused(A, "resize"),
    ),
    Attack(
        "resize_via_reshape",
        VIEW + wrap("a.reshape(4).resize(8, refcheck=False)", "return 1"),
        E,
        refused(A, "resize"),
    ),
    Attack(
        "resize_transposed", VIEW + wrap("a.T.resize(8, refcheck=False)", "return 1"), E, refused(A, "resize")
    ),
    Attack(
        "resize_ufunc_result",
        wrap("b = np.ones(3) + 1", "b.resize(9, refcheck=False)", "return 1"),
        E,
        refused(A, "resize"),
    ),
    Attack(
        "resize_matmul_result",
        wrap("b = np.eye(2) @ np.eye(2)", "b.resize(9, refcheck=False)", "return 1"),
        E,
        refused(A, "resize"),
    ),
    Attack(
        "resize_linalg_result",
        wrap("u = np.linalg.svd(np.eye(2))[0]", "u.resize(9, refcheck=False)", "return 1"),
        E,
        refused(A, "resize"),
    ),
    Attack(
        "resize_api_array",
        wrap(
            "e = pySpatial.reconstruct(input_scene).extrinsics[0]", "e.resize(99, refcheck=False)", "return 1"
        ),
        E,
        refused(A, "resize"),
    ),
    Attack(
        "resize_pose_tool_result",
        wrap(
            "e = pySpatial.reconstruct(input_scene).extrinsics[0]",
            "pySpatial.turn_around(e).resize(9)",
            "return 1",
        ),
        E,
        refused(A, "resize"),
    ),
    Attack(
        "resize_scalar_route",
        wrap("s = np.zeros(2).sum()", "s.reshape(1).resize(9, refcheck=False)", "return 1"),
        E,
        refused(A, "resize"),
    ),
    Attack("resize_scalar", wrap("return np.float64(1).resize(3)"), E, refused(S, "resize")),
    Attack("resize_index_scalar", wrap("return np.zeros(3)[0].resize(3)"), E, refused(S, "resize")),
    # in-place writers and buffer flags
    Attack("put", wrap("np.zeros(3).put([0], [1])", "return 1"), E, refused(A, "put")),
    Attack("fill_view", VIEW + wrap("v.fill(7)", "return 1"), E, refused(A, "fill")),
    Attack("sort_in_place", wrap("np.zeros(3).sort()", "return 1"), E, refused(A, "sort")),
    Attack("partition", wrap("np.zeros(3).partition(1)", "return 1"), E, refused(A, "partition")),
    Attack("byteswap_in_place", wrap("np.zeros(3).byteswap(True)", "return 1"), E, refused(A, "byteswap")),
    Attack("scalar_byteswap", wrap("return np.int64(1).byteswap()"), E, refused(S, "byteswap")),
    Attack("choose", wrap("return np.zeros(3, dtype=np.int64).choose([1, 2])"), E, refused(A, "choose")),
    # raw memory: buffers, strides, flags, iterators
    Attack("strides_read", wrap("return np.zeros(3).strides"), E, refused(A, "strides")),
    Attack("flags_read", wrap("return np.zeros(3).flags"), E, refused(A, "flags")),
    Attack("flat_iterator", wrap("return np.zeros(3).flat"), E, refused(A, "flat")),
    Attack("nbytes", wrap("return np.zeros(3).nbytes"), E, refused(A, "nbytes")),
    Attack("tofile_scalar", wrap("return np.float64(1).tofile"), R, "'.tofile' is not available"),
    Attack("scalar_data", wrap("return np.float64(1).data"), R, "'.data' is not available"),
    Attack(
        "scalar_reshape_ptr",
        wrap("return np.float64(1).reshape(1).searchsorted(0)"),
        E,
        refused(A, "searchsorted"),
    ),
    Attack("dump", wrap("return np.zeros(2).dump"), R, "'.dump' is not available"),
    # dtypes: object, structured, raw records, strings, by every spelling of astype
    Attack(
        "astype_O", wrap("return np.zeros(2).astype('O')"), E, "TypeError: astype(object) is not available"
    ),
    Attack(
        "astype_object_type",
        wrap("return np.zeros(2).astype(dict)"),
        E,
        "TypeError: astype(object) is not available",
    ),
    Attack(
        "astype_keyword",
        wrap("return np.zeros(2).astype(dtype='O')"),
        E,
        "TypeError: astype(object) is not available",
    ),
    Attack(
        "astype_structured",
        wrap("return np.zeros(2).astype([('a', 'O')])"),
        E,
        "TypeError: astype([('a', 'O')]) is not available",
    ),
    Attack(
        "astype_bytes", wrap("return np.zeros(2).astype('S8')"), E, "TypeError: astype(|S8) is not available"
    ),
    Attack(
        "astype_datetime",
        wrap("return np.zeros(2).astype('M8[s]')"),
        E,
        "TypeError: astype(datetime64[s]) is not available",
    ),
    Attack(
        "scalar_astype_O",
        wrap("return np.float64(1).astype('O')"),
        E,
        "TypeError: astype(object) is not available",
    ),
    Attack(
        "item_astype_O",
        wrap("return np.zeros((2, 2))[0].astype('O')"),
        E,
        "TypeError: astype(object) is not available",
    ),
    Attack(
        "array_structured",
        wrap("return np.array([(1,)], dtype=[('a', 'O')])"),
        E,
        "numpy arrays of dtype [('a', 'O')]",
    ),
    Attack(
        "zeros_structured",
        wrap("return np.zeros(2, dtype=[('a', 'i8'), ('b', 'f8')])"),
        E,
        "are not available in the sandbox",
    ),
    Attack("dtype_fields", wrap("return np.zeros(2).dtype.fields"), E, refused("dtype", "fields")),
    Attack("dtype_type", wrap("return np.zeros(2).dtype.type"), E, refused("dtype", "type")),
    Attack("dtype_descr", wrap("return np.zeros(2).dtype.descr"), E, refused("dtype", "descr")),
    Attack("numpy_type_attribute", wrap("return np.float64.fromhex"), E, refused("np.float64", "fromhex")),
    Attack("numpy_type_mro_walk", wrap("return np.float64.mro"), R, "'.mro' is not available"),
    Attack(
        "hasattr_resize",
        wrap("return [hasattr(np.zeros(1), 'resize'), hasattr(np.zeros(1), 'shape')]"),
        OK,
        "False\nTrue",
    ),
]
ATTACKS += NUMPY_SURFACE_ATTACKS


# --- issue 38: numpy callables take only the arguments they list; only numeric dtypes, in and out ---
def keyword(label: str, name: str) -> str:
    return f"TypeError: {label}({name}=...) is not available in the sandbox"


def positional(label: str) -> str:
    return f"TypeError: {label}() takes "


def made(label: str, dtype: str = "object") -> str:
    return f"TypeError: {label} would make a numpy array of dtype {dtype}; only numbers"


def dtype_refused(dtype: str) -> str:
    return f"TypeError: numpy arrays of dtype {dtype} are not available in the sandbox"


INTS = "np.zeros(4096, dtype=np.int64)"
OUT = wrap("o = np.zeros(3)")
STRINGS = "np.array(['ab', 'c'], dtype='T')"
ARGUMENT_AND_DTYPE_ATTACKS = [
    # uninitialised memory: `where=False` returns an output buffer numpy never wrote
    Attack(
        "ufunc_where", wrap(f"return np.abs({INTS}, where=False).tolist()"), E, keyword("np.abs", "where")
    ),
    Attack(
        "binary_ufunc_where",
        wrap("return np.maximum(np.zeros(64), 1, where=False).tolist()"),
        E,
        keyword("np.maximum", "where"),
    ),
    Attack(
        "clip_where", wrap("return np.clip(np.zeros(64), 0, 1, where=False)"), E, keyword("np.clip", "where")
    ),
    Attack(
        "method_clip_where",
        wrap("return np.zeros(64).clip(0, 1, where=False)"),
        E,
        keyword("array.clip", "where"),
    ),
    Attack(
        "scalar_clip_where",
        wrap("return np.float64(1).clip(0, 1, where=False)"),
        E,
        keyword("numpy scalar.clip", "where"),
    ),
    Attack("sqrt_where", wrap("return np.sqrt(np.ones(64), where=False)"), E, keyword("np.sqrt", "where")),
    Attack(
        "sum_where",
        wrap("return np.sum(np.ones(3), where=[True, False, True])"),
        E,
        keyword("np.sum", "where"),
    ),
    Attack(
        "max_initial_where",
        wrap("return np.zeros(3).max(initial=5, where=False)"),
        E,
        keyword("array.max", "initial"),
    ),
    Attack("mean_where", wrap("return np.ones(3).mean(where=False)"), E, keyword("array.mean", "where")),
    # out= by keyword and by position: writes into (and returns) a buffer of the caller's choosing
    Attack("ufunc_out", OUT + wrap("return np.sqrt(np.ones(3), out=o)"), E, keyword("np.sqrt", "out")),
    Attack("ufunc_positional_out", OUT + wrap("np.abs(np.ones(3), o)", "return o"), E, positional("np.abs")),
    Attack("binary_positional_out", OUT + wrap("return np.maximum(o, o, o)"), E, positional("np.maximum")),
    Attack(
        "sum_out", wrap("o = np.zeros(())", "return np.sum(np.ones(3), out=o)"), E, keyword("np.sum", "out")
    ),
    Attack("method_sum_positional_out", OUT + wrap("return o.sum(0, None, o)"), E, positional("array.sum")),
    Attack("take_out", OUT + wrap("return o.take([0], 0, o)"), E, positional("array.take")),
    Attack("take_out_keyword", OUT + wrap("return o.take([0], out=o)"), E, keyword("array.take", "out")),
    Attack("round_out", OUT + wrap("return o.round(2, o)"), E, positional("array.round")),
    Attack(
        "cumsum_positional_out", OUT + wrap("return np.cumsum(o, 0, None, o)"), E, positional("np.cumsum")
    ),
    Attack("dot_out", wrap("o = np.zeros(())", "return np.dot(o, o, o)"), E, positional("np.dot")),
    Attack(
        "matmul_out", wrap("o = np.eye(2)", "return np.matmul(o, o, out=o)"), E, keyword("np.matmul", "out")
    ),
    Attack(
        "concatenate_out",
        OUT + wrap("return np.concatenate([o[:1], o[1:]], out=o)"),
        E,
        keyword("np.concatenate", "out"),
    ),
    Attack(
        "median_overwrite", OUT + wrap("return np.median(o, overwrite_input=True)"), E, "overwrite_input=...)"
    ),
    # casting, order, subok, like, signature: other routes to other dtypes or other array types
    Attack("signature_object", wrap("return np.maximum([1], [2], signature='OO->O')"), E, "(signature=...)"),
    Attack("ufunc_dtype_object", wrap("return np.sin([1.0], dtype='O')"), E, keyword("np.sin", "dtype")),
    Attack(
        "astype_casting",
        wrap("return np.zeros(2).astype(int, casting='unsafe')"),
        E,
        keyword("array.astype", "casting"),
    ),
    Attack("array_order", wrap("return np.array([1], order='F')"), E, keyword("np.array", "order")),
    Attack("array_like", wrap("return np.array([1], like=np.zeros(1))"), E, keyword("np.array", "like")),
    Attack("zeros_like_subok", wrap("return np.zeros_like(np.ones(2), subok=False)"), E, "(subok=...)"),
    # ufunc methods, each with out= and where= of its own: the np functions offer no attribute
    Attack("ufunc_reduce", wrap("return np.maximum.reduce([1, 2])"), E, refused("np.maximum", "reduce")),
    Attack("ufunc_accumulate", wrap("return np.maximum.accumulate"), E, refused("np.maximum", "accumulate")),
    Attack("ufunc_outer", wrap("return np.minimum.outer"), E, refused("np.minimum", "outer")),
    Attack("ufunc_at", wrap("return np.minimum.at"), E, refused("np.minimum", "at")),
    Attack("ufunc_reduceat", wrap("return np.arctan2.reduceat"), E, refused("np.arctan2", "reduceat")),
    Attack(
        "clip_signature",
        wrap("return str(np.ones(2).clip(0, 1, signature='OOO->O').dtype)"),
        E,
        keyword("array.clip", "signature"),
    ),
    Attack(
        "clip_dtype",
        wrap("return str(np.ones(2).clip(0, 1, dtype='O').dtype)"),
        E,
        keyword("array.clip", "dtype"),
    ),
    Attack("method_attribute", wrap("return np.zeros(2).sum.reduce"), E, refused("array.sum", "reduce")),
    Attack("np_empty_like", wrap("return np.empty_like(np.zeros(2))"), E, refused("np", "empty_like")),
    # StringDType 'T': np.maximum(t, t, out=t) on two of them crashed the worker with SIGSEGV
    Attack("string_dtype", wrap(f"return str(({STRINGS}).dtype)"), E, dtype_refused("StringDType()")),
    Attack(
        "string_dtype_maximum_out",
        wrap(f"t = {STRINGS}", "np.maximum(t, t, out=t)", "return 1"),
        E,
        dtype_refused("StringDType()"),
    ),
    Attack(
        "string_dtype_positional",
        wrap("return str((np.array(['a'], 'T')).dtype)"),
        E,
        dtype_refused("StringDType()"),
    ),
    Attack(
        "astype_string_dtype",
        wrap("return np.zeros(2).astype('T')"),
        E,
        "astype(StringDType()) is not available",
    ),
    # other non-numeric dtypes, made from values rather than asked for
    Attack("unicode_array", wrap("return str((np.array(['a', 'b'])).dtype)"), E, made("np.array", "<U1")),
    Attack("unique_strings", wrap("return str((np.unique(['b', 'a'])).dtype)"), E, made("np.unique", "<U1")),
    Attack("sort_strings", wrap("return str((np.sort(['b', 'a'])).dtype)"), E, made("np.sort", "<U1")),
    Attack("bytes_array", wrap("return str((np.asarray(b'abc')).dtype)"), E, made("np.asarray", "|S3")),
    Attack(
        "where_strings",
        wrap("return str((np.where([True], ['a'], ['b'])).dtype)"),
        E,
        made("np.where", "<U1"),
    ),
    Attack("generator_array", wrap("return str((np.array(i for i in range(3))).dtype)"), E, made("np.array")),
    # object arrays through operators: a Python int beyond 64 bits turns the list into objects
    Attack("object_by_addition", wrap("return str((np.arange(3) + [0, 0, 10**30]).dtype)"), E, made("'+'")),
    Attack("object_by_reflected", wrap("return str(([10**30] - np.arange(1)).dtype)"), E, made("'-'")),
    Attack("object_by_scalar", wrap("return str((np.int64(1) + [10**30]).dtype)"), E, made("'+'")),
    Attack("object_by_matmul", wrap("return str((np.ones(2) @ [[10**30], [1]]).dtype)"), E, made("'@'")),
    Attack("object_by_power", wrap("return str((np.arange(2) ** [10**30, 1]).dtype)"), E, made("'**'")),
    Attack("object_by_or", wrap("return str((np.arange(1) | [10**30]).dtype)"), E, made("'|'")),
    Attack("object_by_modulo", wrap("return str((np.arange(2) % [10**30, 1]).dtype)"), E, made("'%'")),
    Attack(
        "object_in_place_name",
        wrap("s = np.int64(1)", "s += [10**30]", "return str(s.dtype)"),
        E,
        made("'+='"),
    ),
    Attack(
        "object_in_place_item",
        wrap("box = [np.int64(1)]", "box[0] += [10**30]", "return str(box[0].dtype)"),
        E,
        made("'+='"),
    ),
    Attack(
        "object_in_place_dict",
        wrap("d = {'k': np.float64(1)}", "d['k'] += [10**30]", "return str(d['k'].dtype)"),
        E,
        made("'+='"),
    ),
    # ... through the builtins and math functions that do arithmetic in C
    Attack("object_by_sum", wrap("return str((sum([np.zeros(2), [10**30, 1]])).dtype)"), E, made("sum()")),
    Attack("object_by_pow", wrap("return str((pow(np.arange(2), [10**30, 1])).dtype)"), E, made("pow()")),
    Attack(
        "object_by_math_prod",
        wrap("return str((math.prod([np.arange(2), [10**30, 1]])).dtype)"),
        E,
        made("math.prod"),
    ),
    # ... through numpy functions and methods, by keyword, by position and by value
    Attack("cumsum_dtype_object", wrap("return np.cumsum([1, 2], dtype='O')"), E, OBJECT_DTYPE),
    Attack("cumsum_positional_object", wrap("return np.cumsum([1, 2], 0, 'O')"), E, OBJECT_DTYPE),
    Attack("method_cumsum_object", wrap("return str((np.ones(2).cumsum(dtype='O')).dtype)"), E, OBJECT_DTYPE),
    Attack("method_sum_object", wrap("return np.ones(2).sum(0, 'O')"), E, OBJECT_DTYPE),
    Attack("method_mean_object", wrap("return np.ones(2).mean(dtype='O')"), E, OBJECT_DTYPE),
    Attack("arange_big_ints", wrap("return str(np.arange(0, 10**30, 10**29).dtype)"), E, made("np.arange")),
    Attack("arange_object", wrap("return np.arange(3, dtype='O')"), E, OBJECT_DTYPE),
    Attack("linspace_object", wrap("return np.linspace(0, 1, 3, dtype='O')"), E, OBJECT_DTYPE),
    Attack("eye_object", wrap("return np.eye(2, dtype='O')"), E, OBJECT_DTYPE),
    Attack("zeros_like_object", wrap("return np.zeros_like(np.ones(2), 'O')"), E, OBJECT_DTYPE),
    Attack("subarray_dtype", wrap("return np.zeros(2, dtype='(2,)f8')"), E, "'(2,)f8' is not a numpy dtype"),
    Attack(
        "fields_dtype", wrap("return np.ones(2, dtype='i4,f8')"), E, "numpy arrays of dtype [('f0', '<i4')"
    ),
    Attack(
        "method_dot_object",
        wrap("return str((np.ones((1, 2)).dot([[10**30], [1]])).dtype)"),
        E,
        made("array.dot"),
    ),
    Attack("maximum_object", wrap("return np.maximum(np.arange(2), [10**30, 1])"), E, made("np.maximum")),
    Attack("unknown_dtype", wrap("return np.zeros(2, dtype='no such')"), E, "'no such' is not a numpy dtype"),
    # a refused dtype's message names it without its heap address (numpy's own message did not)
    Attack(
        "address_in_dtype_error",
        F
        + wrap("try:", "    np.zeros(2, dtype=f)", "except TypeError as error:", "    return error.args[0]"),
        OK,
        f"{HIDDEN} is not a numpy dtype; use np.float64, np.float32, np.int64, np.int32, np.uint8, float, "
        "int or bool",
    ),
    # `%=` on an item formats text too: it hides addresses like every other route
    Attack(
        "address_percent_item", F + wrap("text = ['%r']", "text[0] %= (f,)", "return text[0]"), OK, HIDDEN
    ),
]
ATTACKS += ARGUMENT_AND_DTYPE_ATTACKS


def outcome_problem(attack: Attack, result) -> str | None:
    """None when `result` is exactly how `attack` must end, else what differs."""
    if attack.kind == "ok":  # harmless by construction (hidden addresses, replaced surrogates)
        if not result.ok or result.clue_text != attack.reason:
            got = f"ok={result.ok} {result.clue_text!r} {result.error!r}"
            return f"expected ok with {attack.reason!r}, got {got}"
        if attack.stdout is not None and result.stdout != attack.stdout:
            return f"expected stdout {attack.stdout!r}, got {result.stdout!r}"
        result.clue_text.encode("utf-8")
        result.stdout.encode("utf-8")
        return None
    if result.ok:
        return f"was not stopped: {result.clue_text!r}"
    if result.error_kind != attack.kind or attack.reason not in result.error:
        return f"expected {attack.kind} with {attack.reason!r}, got {result.error_kind}: {result.error!r}"
    if result.clue_text is not None or result.clue_images:
        return "a failed run carried a clue"
    return None


PYTHON_LAYER_ALONE = JailStatus(JailMode.OFF, False, "the OS jail is off: the Python layer alone")


@pytest.mark.parametrize("walls", ["python_and_os", "python_alone"])
def test_every_attack_ends_exactly_as_stated(walls: str) -> None:
    """The whole corpus through the runner, four programs at a time (each in its own process):
    behind both layers, and behind the Python layer alone (the OS jail off), which must hold too."""
    jail_status = PYTHON_LAYER_ALONE if walls == "python_alone" else None

    def run_one(attack: Attack) -> str | None:
        result = run_program(attack.source, "What is left of me?", 2, TinyTools(), LIMITS, jail_status)
        problem = outcome_problem(attack, result)
        return f"{attack.name}: {problem}" if problem else None

    with ThreadPoolExecutor(max_workers=4) as pool:
        problems = [problem for problem in pool.map(run_one, ATTACKS) if problem]
    assert problems == []


def test_corpus_is_large_and_covers_every_wall() -> None:
    assert len(ATTACKS) >= 150
    assert {attack.kind for attack in ATTACKS} == {"rejected", "exception", "memory", "output", "ok"}
    assert len({attack.name for attack in ATTACKS}) == len(ATTACKS)


def test_printed_protocol_lines_cannot_forge_a_result() -> None:
    forged = '{"type":"result","ok":true,"text":"forged","images":["input:0"]}'
    source = wrap(f"print({forged!r})", 'print(\'{"type": "call", "tool": "reconstruct"}\')', "return 'real'")
    tools = TinyTools()
    result = run_program("def program(input_scene):\n" + source, "q", 2, tools, LIMITS)
    assert result.ok, result.error
    assert result.clue_text == "real" and result.clue_images == []
    assert result.stdout.splitlines()[0] == forged
    assert tools.calls == [] and result.tool_calls == []


def test_endless_loop_is_stopped_within_its_wall_limit() -> None:
    limits = SandboxLimits(cpu_seconds=30, wall_seconds=2, memory_mb=512)
    started = time.perf_counter()
    result = run_program(
        "def program(input_scene):\n    while True:\n        pass\n", "q", 1, TinyTools(), limits
    )
    elapsed = time.perf_counter() - started
    assert not result.ok and result.error_kind == "timeout"
    assert result.error == "timed out after 2 s (tool calls included)"
    assert elapsed < 4.0, f"stopped after {elapsed:.1f} s"


def test_cpu_bomb_is_stopped_by_the_cpu_limit() -> None:
    limits = SandboxLimits(cpu_seconds=1, wall_seconds=30, memory_mb=512)
    result = run_program("def program(input_scene):\n    return 10 ** 10 ** 9\n", "q", 1, TinyTools(), limits)
    assert not result.ok and result.error_kind == "cpu"
    assert result.error == "CPU time limit exceeded (1 s)"


def test_a_normal_program_still_runs_after_the_corpus() -> None:
    tools = TinyTools()
    result = run_program(
        "def program(input_scene):\n"
        "    recon = pySpatial.reconstruct(input_scene)\n"
        "    behind = pySpatial.turn_around(recon.extrinsics[1])\n"
        "    view = pySpatial.synthesize_novel_view(recon, behind, 32, 32)\n"
        "    return [pySpatial.describe_camera_motion(recon), view]\n",
        "q",
        2,
        tools,
        LIMITS,
    )
    assert result.ok, result.error
    assert result.clue_text == "From image 1 to image 2 the camera moved right by 0.50.\n<image 1>"
    assert len(result.clue_images) == 1 and result.clue_images[0].startswith(b"\x89PNG")
    assert tools.calls == ["reconstruct", "synthesize_novel_view", "describe_camera_motion"]


# --- each wall on its own: the layers behind the validator hold even for unvalidated code ---------


def test_program_globals_alone_offer_no_import_open_or_numpy_files() -> None:
    names = program_globals(OutputCapture(100), {})
    refusals = {
        "__import__('os')": "name '__import__' is not defined",
        "open('/etc/hostname')": "name 'open' is not defined",
        "getattr(np, 'load')": "name 'getattr' is not defined",
        "np.load('x.npy')": "np.load is not available in the sandbox",
        "np.lib": "np.lib is not available in the sandbox",
        "np.linalg.lapack_lite": "np.linalg.lapack_lite is not available in the sandbox",
        "math.sys": "math.sys is not available in the sandbox",
        "list(range(10**9))": "range of more than 10000000 items",
    }
    for code, message in refusals.items():
        with pytest.raises((NameError, AttributeError, ValueError), match=re.escape(message)):
            exec(code, dict(names))


def test_the_numpy_stand_ins_alone_refuse_unlisted_arguments_and_non_numeric_dtypes() -> None:
    """Without the validator's checks: the callables and operator helpers a program's names hold."""
    names = program_globals(OutputCapture(100), {})
    stand_in, attribute = names["np"], names[ATTRIBUTE_FUNCTION_NAME]
    big = [10**30, 1]
    refusals = {
        "np.abs(where=...)": lambda: stand_in.abs(np.zeros(64), where=False),
        "np.maximum() takes x1, x2 by position": lambda: stand_in.maximum(np.ones(2), 1, np.zeros(2)),
        "array.clip(where=...)": lambda: attribute(np.zeros(64), "clip")(0, 1, where=False),
        "array.take() takes indices, axis by position": lambda: attribute(np.ones(2), "take")(
            [0], 0, np.ones(1)
        ),
        "np.maximum.reduce is not available": lambda: attribute(stand_in.maximum, "reduce"),
        "numpy arrays of dtype object": lambda: stand_in.cumsum([1, 2], dtype="O"),
        "numpy arrays of dtype StringDType()": lambda: stand_in.array(["a"], "T"),
        "np.unique would make a numpy array of dtype <U1": lambda: stand_in.unique(["b", "a"]),
        "'+' would make a numpy array of dtype object": lambda: names[RESULT_FUNCTION_NAME](
            np.arange(2) + big, "+"
        ),
        "'+=' would make a numpy array": lambda: names[IN_PLACE_ITEM_FUNCTION_NAME](
            [np.int64(1)], 0, big, "+="
        ),
        "sum() would make a numpy array": lambda: names["__builtins__"]["sum"]([np.zeros(2), big]),
        "math.prod would make a numpy array": lambda: names["math"].prod([np.arange(2), big]),
    }
    for message, action in refusals.items():
        with pytest.raises((TypeError, AttributeError), match=re.escape(message)):
            action()


PROCESS_WALL_SCRIPT = """
import errno, json, os, sys
sys.path.insert(0, sys.argv[1])
from services.agent.sandbox import worker
from services.agent.sandbox.worker import apply_resource_limits, arm_audit_hook

def outcome(action):
    try:
        action()
        return "allowed"
    except RuntimeError as error:
        return str(error)
    except OSError as error:
        return errno.errorcode.get(error.errno, str(error))

report = {"new_fd": outcome(lambda: os.open("/dev/null", os.O_RDONLY))}
apply_resource_limits(cpu_seconds=5, memory_mb=512)
report["new_fd_limited"] = outcome(lambda: os.open("/dev/null", os.O_RDONLY))
arm_audit_hook(compile("1", "<program>", "exec"))
# the block lists live in the hook's closure: emptying the module's copies changes nothing
worker.BLOCKED_EVENTS = worker.BLOCKED_EVENT_MODULES = frozenset()
report["open"] = outcome(lambda: open(sys.argv[1] + "/pyproject.toml"))
report["system"] = outcome(lambda: os.system("true"))
report["listdir"] = outcome(lambda: os.listdir("/"))
report["import"] = outcome(lambda: __import__("xml.dom.minidom"))
report["exec"] = outcome(lambda: exec("1"))
sys.stdout.write(json.dumps(report))
"""


def test_process_limits_and_audit_hook_alone_refuse_files_processes_and_imports() -> None:
    completed = subprocess.run(
        [sys.executable, "-I", "-c", PROCESS_WALL_SCRIPT, str(REPO_ROOT)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert completed.returncode == 0, completed.stderr
    report = json.loads(completed.stdout)
    assert report["new_fd"] == "allowed"
    assert report["new_fd_limited"] == "EMFILE"  # RLIMIT_NOFILE=0
    assert report["open"] == "operation 'open' is not allowed in the sandbox"
    assert report["system"] == "operation 'os.system' is not allowed in the sandbox"
    assert report["listdir"] == "operation 'os.listdir' is not allowed in the sandbox"
    assert report["import"] == "operation 'import' is not allowed in the sandbox"
    assert report["exec"] == "operation 'compile' is not allowed in the sandbox"


# --- tool-call floods: every call counts against the call budget and the wall clock ---------------
class SlowTools(TinyTools):
    """Each rendering takes the parent 0.2 s: cheap for the program, not for the agent."""

    def synthesize_novel_view(self, extrinsic: list[list[float]], width: int, height: int) -> bytes:
        time.sleep(0.2)
        return super().synthesize_novel_view(extrinsic, width, height)


FLOOD = (
    "def program(input_scene):\n"
    "    recon = pySpatial.reconstruct(input_scene)\n"
    "    n = 0\n"
    "    while True:\n"
    "        try:\n"
    "            {call}\n"
    "        except Exception:\n"
    "            pass\n"
    "        n += 1\n"
)
FLOOD_CALLS = {
    "camera_motion": "pySpatial.describe_camera_motion(recon)",
    "reconstruct": "pySpatial.reconstruct(input_scene)",
    "novel_views": "pySpatial.synthesize_novel_view(recon, recon.extrinsics[0], 16, 16)",
}


@pytest.mark.parametrize("call", list(FLOOD_CALLS))
def test_a_tool_call_flood_ends_at_the_call_budget_even_when_the_program_catches_the_refusal(
    call: str,
) -> None:
    limits = SandboxLimits(cpu_seconds=5, wall_seconds=20, memory_mb=512, max_tool_calls=6)
    started = time.perf_counter()
    result = run_program(FLOOD.format(call=FLOOD_CALLS[call]), "q", 2, TinyTools(), limits)
    assert not result.ok and result.error_kind == "tool_limit", result.error
    assert result.error == "too many tool calls: the limit is 6 per program"
    assert len(result.tool_calls) == 6
    assert time.perf_counter() - started < 10  # ended at the budget, not at the wall clock


def test_time_in_the_parents_tools_counts_against_the_wall_clock() -> None:
    limits = SandboxLimits(cpu_seconds=5, wall_seconds=1.5, memory_mb=512, max_tool_calls=1000)
    started = time.perf_counter()
    result = run_program(FLOOD.format(call=FLOOD_CALLS["novel_views"]), "q", 2, SlowTools(), limits)
    elapsed = time.perf_counter() - started
    assert not result.ok and result.error_kind == "timeout", result.error
    assert result.error == "timed out after 1.5 s (tool calls included)"
    assert 4 <= len(result.tool_calls) <= 9  # 0.2 s each within 1.5 s
    assert elapsed < 5
