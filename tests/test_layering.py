"""The layering holds in the import graph, and the check catches each kind of forbidden import.

The rules are in tests/support/import_graph.py. Each case below writes one forbidden import into
an in-memory overlay of the real tree (at module level, inside a function, under TYPE_CHECKING,
or relative) and asserts that the checker reports exactly that one violation.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.import_graph import import_graph, read_tree, violations

ROOT = Path(__file__).resolve().parents[1]
TREE = read_tree(ROOT)

AT_MODULE_LEVEL = "\n{statement}\n"
IN_A_FUNCTION = "\n\ndef _added_for_the_test():\n    {statement}\n"
UNDER_TYPE_CHECKING = "\nfrom typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n    {statement}\n"


def with_import(module: str, statement: str, form: str = AT_MODULE_LEVEL) -> dict[str, str]:
    """The real tree with `statement` added to `module`'s source (nothing is written to disk)."""
    assert module in TREE, module
    return {**TREE, module: TREE[module] + form.format(statement=statement)}


def test_the_tree_keeps_its_layering() -> None:
    assert violations(TREE) == []


def test_the_graph_sees_relative_and_package_imports() -> None:
    graph = import_graph(TREE)
    backbone = graph["services.recon.backbones.classical.backbone"]
    assert {"services.recon.backbones.base", "services.recon.backbones.classical.solve"} <= backbone
    assert "services.agent.sandbox.runner" in graph["services.agent.sandbox"]  # under TYPE_CHECKING


SHARED = ": shared imports nothing outside shared"
LAYER = ": shared.{layer} may import only {allowed}"
SERVICES = ": recon and agent never import each other"
WORKER = ": the sandbox worker imports only services.agent.sandbox and shared"

CASES = {
    "shared imports services": (
        "shared.local.nginx",
        "from services.recon.preview import subsample_indices",
        IN_A_FUNCTION,
        "shared.local.nginx imports services.recon.preview" + SHARED,
    ),
    "shared imports tests": (
        "shared.wire.client",
        "from tests.support import realdata",
        UNDER_TYPE_CHECKING,
        "shared.wire.client imports tests.support.realdata" + SHARED,
    ),
    "shared imports cli": (
        "shared.imaging.exif",
        "import cli.console",
        AT_MODULE_LEVEL,
        "shared.imaging.exif imports cli.console" + SHARED,
    ),
    "geometry imports imaging": (
        "shared.geometry.rendering",
        "from ..imaging import codecs",
        AT_MODULE_LEVEL,
        "shared.geometry.rendering imports shared.imaging.codecs"
        + LAYER.format(layer="geometry", allowed="geometry"),
    ),
    "imaging imports geometry": (
        "shared.imaging.codecs",
        "from shared.geometry.poses import validate_extrinsic",
        IN_A_FUNCTION,
        "shared.imaging.codecs imports shared.geometry.poses"
        + LAYER.format(layer="imaging", allowed="imaging"),
    ),
    "navigation imports synthetic": (
        "shared.navigation.route",
        "from shared.synthetic.render import look_at",
        IN_A_FUNCTION,
        "shared.navigation.route imports shared.synthetic.render"
        + LAYER.format(layer="navigation", allowed="geometry, navigation"),
    ),
    "questions imports wire": (
        "shared.questions.choices",
        "from shared.wire import schemas",
        UNDER_TYPE_CHECKING,
        "shared.questions.choices imports shared.wire.schemas"
        + LAYER.format(layer="questions", allowed="geometry, questions"),
    ),
    "wire imports local": (
        "shared.wire.api",
        "from shared.local.services import REPO_ROOT",
        IN_A_FUNCTION,
        "shared.wire.api imports shared.local.services"
        + LAYER.format(layer="wire", allowed="geometry, imaging, navigation, questions, wire"),
    ),
    "synthetic imports wire": (
        "shared.synthetic.photo",
        "from shared.wire.settings import ReconSettings",
        AT_MODULE_LEVEL,
        "shared.synthetic.photo imports shared.wire.settings"
        + LAYER.format(layer="synthetic", allowed="geometry, imaging, navigation, questions, synthetic"),
    ),
    "recon imports agent": (
        "services.recon.preview",
        "from services.agent.clue_views import clue_views",
        IN_A_FUNCTION,
        "services.recon.preview imports services.agent.clue_views" + SERVICES,
    ),
    "agent imports recon": (
        "services.agent.recon_tools",
        "from services.recon import errors",
        UNDER_TYPE_CHECKING,
        "services.agent.recon_tools imports services.recon.errors" + SERVICES,
    ),
    "the sandbox worker imports the agent's app layer": (
        "services.agent.sandbox.output",
        "import services.agent.llm",
        IN_A_FUNCTION,
        "services.agent.sandbox.output imports services.agent.llm" + WORKER,
    ),
    "the sandbox package imports the agent's app layer": (
        "services.agent.sandbox",
        "from services.agent import planner",
        UNDER_TYPE_CHECKING,
        "services.agent.sandbox imports services.agent.planner" + WORKER,
    ),
    "a cycle in recon": (
        "services.recon.cache",
        "from services.recon.service import ReconService",
        UNDER_TYPE_CHECKING,
        "import cycle in services.recon: services.recon.cache, services.recon.jobs, services.recon.service",
    ),
    "a cycle in the sandbox": (
        "services.agent.sandbox.protocol",
        "from services.agent.sandbox import runner",
        IN_A_FUNCTION,
        "import cycle in services.agent: services.agent.sandbox.jail, services.agent.sandbox.messages, "
        "services.agent.sandbox.protocol, services.agent.sandbox.runner, "
        "services.agent.sandbox.worker_process",
    ),
}


@pytest.mark.parametrize("case", CASES)
def test_a_forbidden_import_is_reported(case: str) -> None:
    module, statement, form, expected = CASES[case]
    assert violations(with_import(module, statement, form)) == [expected]
