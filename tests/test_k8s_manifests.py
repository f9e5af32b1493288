"""deploy/k8s/ is valid Kubernetes (checked offline against the schemas kubernetes-validate bundles)
and agrees with the code: probes on the services' health routes and ports, resources, autoscaling,
non-root pods, keys from the Secret, settings that exist.
"""

from __future__ import annotations

import kubernetes_validate
import pytest
import yaml

from shared.wire.settings import DEFAULT_AGENT_PORT, DEFAULT_RECON_PORT, AgentSettings, ReconSettings
from tests.support.processes import REPO_ROOT

K8S_DIR = REPO_ROOT / "deploy" / "k8s"
KUBERNETES_VERSION = "1.30.0"  # oldest release the manifests promise to work on
DOCUMENTS = [
    (path.name, document)
    for path in sorted(K8S_DIR.glob("*.yaml"))
    for document in yaml.safe_load_all(path.read_text())
    if document
]
BY_KIND: dict[tuple[str, str], dict] = {(d["kind"], d["metadata"]["name"]): d for _, d in DOCUMENTS}
SETTING_ENV_NAMES = {
    f"PYSPATIAL_{name.upper()}" for name in (*ReconSettings.model_fields, *AgentSettings.model_fields)
} | {"REDIS_URL"}
APP_PORTS = {"recon": DEFAULT_RECON_PORT, "recon-gpu": DEFAULT_RECON_PORT, "agent": DEFAULT_AGENT_PORT}


def deployments() -> list[dict]:
    return [d for (kind, _), d in BY_KIND.items() if kind == "Deployment"]


@pytest.mark.parametrize("name,document", DOCUMENTS, ids=[f"{n}:{d['kind']}" for n, d in DOCUMENTS])
def test_every_manifest_is_valid_kubernetes(name, document):
    # strict: unknown fields (typos like `readinesProbe`) fail too
    kubernetes_validate.validate(document, KUBERNETES_VERSION, strict=True)


def test_the_validator_rejects_a_broken_manifest():
    broken = next(yaml.safe_load_all((K8S_DIR / "agent.yaml").read_text()))
    broken["spec"]["template"]["spec"]["containers"][0]["readinesProbe"] = {}
    with pytest.raises(kubernetes_validate.ValidationError):
        kubernetes_validate.validate(broken, KUBERNETES_VERSION, strict=True)


def test_the_stack_is_complete():
    for kind, name in [
        ("Deployment", "redis"),
        ("Service", "redis"),
        ("Deployment", "recon"),
        ("Service", "recon"),
        ("Deployment", "agent"),
        ("Service", "agent"),
        ("HorizontalPodAutoscaler", "recon"),
        ("HorizontalPodAutoscaler", "agent"),
        ("Secret", "pyspatial-keys"),
        ("ConfigMap", "pyspatial-config"),
    ]:
        assert (kind, name) in BY_KIND, f"missing {kind} {name}"


@pytest.mark.parametrize("name", ["recon", "recon-gpu", "agent"])
def test_app_pods_have_probes_resources_and_no_root(name):
    deployment = BY_KIND[("Deployment", name)]
    pod = deployment["spec"]["template"]["spec"]
    assert pod["securityContext"]["runAsNonRoot"] is True and pod["securityContext"]["runAsUser"] == 10001
    (container,) = pod["containers"]
    port = APP_PORTS[name]
    assert [p["containerPort"] for p in container["ports"]] == [port]
    assert container["readinessProbe"]["httpGet"] == {"path": "/readyz", "port": port}
    assert container["livenessProbe"]["httpGet"] == {"path": "/healthz", "port": port}
    assert {"cpu", "memory"} <= container["resources"]["requests"].keys()
    assert container["securityContext"]["allowPrivilegeEscalation"] is False
    labels = deployment["spec"]["template"]["metadata"]["labels"]
    service = BY_KIND[("Service", "recon" if name == "recon-gpu" else name)]
    assert service["spec"]["selector"].items() <= labels.items()
    assert service["spec"]["ports"][0]["targetPort"] == port


def test_gpu_pods_ask_for_a_gpu_node():
    pod = BY_KIND[("Deployment", "recon-gpu")]["spec"]["template"]["spec"]
    assert pod["nodeSelector"] and pod["containers"][0]["resources"]["limits"]["nvidia.com/gpu"] == 1


def test_autoscalers_target_the_deployments():
    for name in ("recon", "agent"):
        hpa = BY_KIND[("HorizontalPodAutoscaler", name)]["spec"]
        assert hpa["scaleTargetRef"] == {"apiVersion": "apps/v1", "kind": "Deployment", "name": name}
        assert 2 <= hpa["minReplicas"] < hpa["maxReplicas"]
        assert hpa["metrics"][0]["resource"]["name"] == "cpu"


def test_keys_come_from_the_secret_and_settings_exist():
    secret = BY_KIND[("Secret", "pyspatial-keys")]["stringData"]
    config = BY_KIND[("ConfigMap", "pyspatial-config")]["data"]
    assert set(config) <= SETTING_ENV_NAMES
    for deployment in deployments():
        for container in deployment["spec"]["template"]["spec"]["containers"]:
            for source in container.get("envFrom", []):
                assert ("ConfigMap", source["configMapRef"]["name"]) in BY_KIND
            for variable in container.get("env", []):
                if deployment["metadata"]["name"] != "redis":
                    assert variable["name"] in SETTING_ENV_NAMES, variable["name"]
                reference = variable.get("valueFrom", {}).get("secretKeyRef")
                if reference:
                    assert reference["name"] == "pyspatial-keys" and reference["key"] in secret
                if "KEY" in variable["name"]:
                    assert reference, f"{variable['name']} must come from the Secret, not the manifest"
    recon_env = {
        e["name"]: e
        for e in BY_KIND[("Deployment", "recon")]["spec"]["template"]["spec"]["containers"][0]["env"]
    }
    agent_env = {
        e["name"]: e
        for e in BY_KIND[("Deployment", "agent")]["spec"]["template"]["spec"]["containers"][0]["env"]
    }
    # recon accepts exactly the key the agent sends
    assert recon_env["PYSPATIAL_API_KEYS"]["valueFrom"] == agent_env["PYSPATIAL_RECON_API_KEY"]["valueFrom"]
    assert config["PYSPATIAL_RECON_URL"] == f"http://recon:{DEFAULT_RECON_PORT}"


def test_recon_pods_read_pulled_checkpoints_from_the_hub_cache_a_job_fills():
    claim = BY_KIND[("PersistentVolumeClaim", "pyspatial-hub-cache")]
    assert claim["spec"]["accessModes"] == ["ReadWriteMany"]
    for name in ("recon", "recon-gpu"):
        pod = BY_KIND[("Deployment", name)]["spec"]["template"]["spec"]
        volume = next(v for v in pod["volumes"] if v.get("persistentVolumeClaim"))
        assert volume["persistentVolumeClaim"] == {"claimName": "pyspatial-hub-cache", "readOnly": True}
        mount = next(m for m in pod["containers"][0]["volumeMounts"] if m["name"] == volume["name"])
        assert mount == {"name": volume["name"], "mountPath": "/hf", "readOnly": True}  # the image's HF_HOME
    job = BY_KIND[("Job", "pyspatial-weights-pull")]["spec"]["template"]["spec"]
    (container,) = job["containers"]
    assert container["command"] == ["pyspatial", "weights", "pull"] and container["args"] == ["pi3x"]
    assert container["volumeMounts"] == [{"name": "hub-cache", "mountPath": "/hf"}]
    assert job["securityContext"]["runAsUser"] == 10001


STORE_CLAIM = "pyspatial-store"


def test_recon_pods_share_a_readwritemany_store_of_record():
    claim = BY_KIND[("PersistentVolumeClaim", STORE_CLAIM)]
    assert claim["spec"]["accessModes"] == ["ReadWriteMany"]
    config = BY_KIND[("ConfigMap", "pyspatial-config")]["data"]
    for deployment in ("recon", "recon-gpu"):
        pod = BY_KIND[("Deployment", deployment)]["spec"]["template"]["spec"]
        (volume,) = [
            v for v in pod["volumes"] if v.get("persistentVolumeClaim", {}).get("claimName") == STORE_CLAIM
        ]
        assert not volume["persistentVolumeClaim"].get("readOnly")
        mount = next(m for m in pod["containers"][0]["volumeMounts"] if m["name"] == volume["name"])
        assert mount["mountPath"] == config["PYSPATIAL_STORE_DIR"] and not mount.get("readOnly")
    # the GC keeps the store below its claim
    claim_gb = int(claim["spec"]["resources"]["requests"]["storage"].removesuffix("Gi"))
    assert 0 < float(config["PYSPATIAL_STORE_MAX_GB"]) < claim_gb
