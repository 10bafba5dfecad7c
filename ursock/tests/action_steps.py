"""Runs the steps of the repository's action.yml (a composite GitHub Action) as a runner
would, here: each `run:` step with bash, its `${{ ... }}` expressions substituted (inputs
with their defaults, `env.X`, `github.action_repository`), its `if:` evaluated (the forms
the action uses: `inputs.X == 'v'`, `!=`), $GITHUB_ENV, $GITHUB_PATH and $GITHUB_OUTPUT
carried between steps as a runner carries them. A `uses:` step is not run: its name and
inputs are printed as `USES <action> <json>`.

usage: action_steps.py ACTION_YML STATE_DIR KEY=VALUE...   (the action's inputs)
Prints `OUTPUT name=value` for the action's outputs. STATE_DIR keeps the job's
environment between two uses of the action (start, then stop), as one job would.
"""
import json
import os
import re
import subprocess
import sys

import yaml

action_path, state, *given = sys.argv[1:]
action = yaml.safe_load(open(action_path))
inputs = {k: str(v.get("default", "")) for k, v in action["inputs"].items()}
for kv in given:
    k, v = kv.split("=", 1)
    assert k in inputs, f"no input {k}"
    inputs[k] = v

os.makedirs(state, exist_ok=True)
env_file = os.path.join(state, "env.json")
job_env = json.load(open(env_file)) if os.path.exists(env_file) else {}
path_file = os.path.join(state, "path.json")
job_path = json.load(open(path_file)) if os.path.exists(path_file) else []
temp = os.path.join(state, "runner_temp")
os.makedirs(temp, exist_ok=True)
step_outputs = {}


def expr(text):
    text = text.strip()
    m = re.fullmatch(r"inputs\.([\w-]+)\s*(==|!=)\s*'([^']*)'", text)
    if m:
        equal = inputs[m.group(1)] == m.group(3)
        return equal if m.group(2) == "==" else not equal
    m = re.fullmatch(r"inputs\.([\w-]+)", text)
    if m:
        return inputs[m.group(1)]
    m = re.fullmatch(r"env\.(\w+)", text)
    if m:
        return job_env.get(m.group(1), "")
    m = re.fullmatch(r"steps\.([\w-]+)\.outputs\.([\w-]+)", text)
    if m:
        return step_outputs.get(m.group(1), {}).get(m.group(2), "")
    if text == "github.action_repository":
        return ""
    raise SystemExit(f"unsupported expression: {text}")


def substitute(text):
    return re.sub(r"\$\{\{(.*?)\}\}", lambda m: str(expr(m.group(1))), str(text))


def read_kv(path):
    out = {}
    if os.path.exists(path):
        for line in open(path).read().splitlines():
            if "=" in line:
                k, v = line.split("=", 1)
                out[k] = v
    return out


for step in action["runs"]["steps"]:
    cond = step.get("if")
    if cond is not None and not expr(cond):
        continue
    if "uses" in step:
        with_ = {k: substitute(v) for k, v in step.get("with", {}).items()}
        print("USES", step["uses"], json.dumps(with_), flush=True)
        continue
    files = {n: os.path.join(state, n) for n in ("GITHUB_ENV", "GITHUB_PATH", "GITHUB_OUTPUT")}
    for f in files.values():
        open(f, "w").close()
    env = dict(os.environ)
    env.update(job_env)
    env.update(files)
    env["RUNNER_TEMP"] = temp
    env["PATH"] = os.pathsep.join(job_path + [env["PATH"]])
    for k, v in step.get("env", {}).items():
        env[k] = substitute(v)
    print("STEP", step.get("name", ""), flush=True)
    done = subprocess.run(["bash", "-e", "-c", substitute(step["run"])], env=env)
    if done.returncode != 0:
        print(f"FAILED {step.get('name')} with status {done.returncode}", flush=True)
        sys.exit(1)
    job_env.update(read_kv(files["GITHUB_ENV"]))
    job_path = [p for p in open(files["GITHUB_PATH"]).read().splitlines() if p] + job_path
    if "id" in step:
        step_outputs[step["id"]] = read_kv(files["GITHUB_OUTPUT"])

json.dump(job_env, open(env_file, "w"))
json.dump(job_path, open(path_file, "w"))
for name, out in action.get("outputs", {}).items():
    print(f"OUTPUT {name}={substitute(out['value'])}", flush=True)
