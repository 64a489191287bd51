#!/usr/bin/env python3
"""Reads the Kubernetes manifests of deploy/cluster/k8s/ for tests/cluster/k8s_indexed_job_test.sh.

    k8s_pod.py check SHARDS_JOB.yaml MERGE_JOB.yaml PVC.yaml
        The manifests agree with each other and with what the scripts in them need; prints N.
    k8s_pod.py argv MANIFEST ROOT
        The container's command + args, NUL-separated, as the kubelet would run them: $(VAR)
        references expanded from the container's literal env values (Kubernetes' rules: $$ is
        a $, an unknown $(X) stays as it is), and every volumeMount's mountPath M rewritten to
        ROOT + M (the test's stand-in for the volumes).
    k8s_pod.py env MANIFEST
        The container's env: NAME=VALUE for literal values, NAME alone for valueFrom entries
        (the test supplies those, as the kubelet would).
Exit 0, or 1 with the problems printed. Needs PyYAML (Debian: python3-yaml).
"""
import re
import sys

import yaml


def load(path):
    with open(path, encoding="utf-8") as f:
        docs = [d for d in yaml.safe_load_all(f) if d is not None]
    if len(docs) != 1:
        raise SystemExit(f"{path}: expected one document, found {len(docs)}")
    return docs[0]


def container(job):
    cs = job["spec"]["template"]["spec"]["containers"]
    if len(cs) != 1:
        raise SystemExit(f"{job['metadata']['name']}: expected one container, found {len(cs)}")
    return cs[0]


def literal_env(c):
    return {e["name"]: str(e["value"]) for e in c.get("env", []) if "value" in e}


def k8s_expand(s, env):
    """Kubernetes' $(VAR) expansion of command and args (k8s.io/kubernetes third_party expansion)."""
    out, i = [], 0
    while i < len(s):
        if s[i] == "$" and i + 1 < len(s):
            nxt = s[i + 1]
            if nxt == "$":
                out.append("$")
                i += 2
                continue
            if nxt == "(":
                j = s.find(")", i + 2)
                if j != -1:
                    name = s[i + 2:j]
                    out.append(env[name] if name in env else s[i:j + 1])
                    i = j + 1
                    continue
        out.append(s[i])
        i += 1
    return "".join(out)


def check(shards_path, merge_path, pvc_path):
    p = []
    sj, mj, pvc = load(shards_path), load(merge_path), load(pvc_path)
    for doc, kind in ((sj, "Job"), (mj, "Job"), (pvc, "PersistentVolumeClaim")):
        if doc.get("kind") != kind:
            p.append(f"{doc.get('metadata', {}).get('name')}: kind {doc.get('kind')}, expected {kind}")
    for j in (sj, mj):
        if j.get("apiVersion") != "batch/v1":
            p.append(f"{j['metadata']['name']}: apiVersion {j.get('apiVersion')}")
    s = sj["spec"]
    n = s.get("completions")
    if s.get("completionMode") != "Indexed":
        p.append("shards Job: completionMode is not Indexed (no JOB_COMPLETION_INDEX)")
    if not isinstance(n, int) or n < 1:
        p.append(f"shards Job: completions {n!r}")
    elif not isinstance(s.get("parallelism"), int) or not 1 <= s["parallelism"] <= n:
        p.append(f"shards Job: parallelism {s.get('parallelism')!r} not in 1..{n}")
    if mj["spec"].get("completions", 1) != 1:
        p.append("merge Job: completions must be 1")
    sc, mc = container(sj), container(mj)
    se, me = literal_env(sc), literal_env(mc)
    if se.get("FRAGSIM_SHARDS") != str(n):
        p.append(f"shards Job: FRAGSIM_SHARDS {se.get('FRAGSIM_SHARDS')!r} != completions {n}")
    for k in ("FRAGSIM_SHARDS", "FRAGSIM_RUN", "FRAGSIM_SAMPLES_SCALE"):
        if se.get(k) is None or se.get(k) != me.get(k):
            p.append(f"{k}: shards {se.get(k)!r}, merge {me.get(k)!r} (must be set and equal)")
    if sc.get("image") != mc.get("image"):
        p.append(f"images differ: {sc.get('image')} / {mc.get('image')}")
    for j, c in ((sj, sc), (mj, mc)):
        name = j["metadata"]["name"]
        pod = j["spec"]["template"]["spec"]
        pfp = j["spec"].get("podFailurePolicy")
        if pfp is not None and pod.get("restartPolicy") != "Never":
            p.append(f"{name}: podFailurePolicy needs restartPolicy Never")
        for r in (pfp or {}).get("rules", []):
            cn = r.get("onExitCodes", {}).get("containerName")
            if cn is not None and cn != c["name"]:
                p.append(f"{name}: podFailurePolicy names container {cn}, not {c['name']}")
        for e in c.get("env", []):
            ref = e.get("valueFrom", {}).get("resourceFieldRef")
            if ref and ref.get("containerName", c["name"]) != c["name"]:
                p.append(f"{name}: {e['name']} refers to container {ref.get('containerName')}")
        vols = {v["name"]: v for v in pod.get("volumes", [])}
        for m in c.get("volumeMounts", []):
            if m["name"] not in vols:
                p.append(f"{name}: volumeMount {m['name']} has no volume")
        claims = [v["persistentVolumeClaim"]["claimName"] for v in vols.values()
                  if "persistentVolumeClaim" in v]
        if claims != [pvc["metadata"]["name"]]:
            p.append(f"{name}: claims {claims}, the PVC manifest is {pvc['metadata']['name']}")
    smounts = {m["mountPath"]: m["name"] for m in sc.get("volumeMounts", [])}
    mmounts = {m["mountPath"]: m["name"] for m in mc.get("volumeMounts", [])}
    if smounts != mmounts:
        p.append(f"mounts differ: shards {smounts}, merge {mmounts}")
    svols = {v["name"]: {k: v[k] for k in v if k != "name"}
             for v in sj["spec"]["template"]["spec"].get("volumes", [])}
    mvols = {v["name"]: {k: v[k] for k in v if k != "name"}
             for v in mj["spec"]["template"]["spec"].get("volumes", [])}
    if svols != mvols:
        p.append(f"volumes differ: shards {svols}, merge {mvols}")
    if "ReadWriteMany" not in pvc["spec"].get("accessModes", []):
        p.append("PVC: not ReadWriteMany (shard pods on several nodes write to it)")
    if p:
        print("k8s manifests:\n  " + "\n  ".join(p), file=sys.stderr)
        return 1
    print(n)
    return 0


def argv(path, root):
    j = load(path)
    c = container(j)
    env = literal_env(c)
    words = [k8s_expand(w, env) for w in c.get("command", []) + c.get("args", [])]
    mounts = sorted((m["mountPath"].rstrip("/") for m in c.get("volumeMounts", [])),
                    key=len, reverse=True)
    for mp in mounts:
        pat = re.compile(r"(?<![\w./-])" + re.escape(mp) + r"(?=/|\b|$)")
        words = [pat.sub(lambda _m: root.rstrip("/") + mp, w) for w in words]
    sys.stdout.write("\0".join(words) + "\0")
    return 0


def env(path):
    c = container(load(path))
    for e in c.get("env", []):
        print(f"{e['name']}={e['value']}" if "value" in e else e["name"])
    return 0


def main(a):
    if len(a) == 5 and a[1] == "check":
        return check(a[2], a[3], a[4])
    if len(a) == 4 and a[1] == "argv":
        return argv(a[2], a[3])
    if len(a) == 3 and a[1] == "env":
        return env(a[2])
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
