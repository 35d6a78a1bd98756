//! The cluster examples: examples/slurm/*.sbatch run as Slurm would run them
//! (the job array's environment, without Slurm; tools/slurm-e2e.sh runs them
//! on a real Slurm cluster), and examples/kubernetes/indexed-job.yaml parsed
//! and checked for consistency (no Kubernetes can run here).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-examples-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

fn ok(o: Output) -> Output {
    assert!(o.status.success(), "{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    o
}

const ARGS: &str = "-D res=24 --spp 8 --seed 5";

/// bash SCRIPT with the environment of task `task` of a Slurm array of `count`.
fn sbatch_like(script: &str, out: &Path, task: Option<(u32, u32)>, extra: &[(&str, &str)]) -> Output {
    let mut c = Command::new("bash");
    c.arg(root().join("examples/slurm").join(script))
        .env("PENUMBRA", env!("CARGO_BIN_EXE_penumbra"))
        .env("SCENE", root().join("scenes/cornell-box.xml"))
        .env("OUTDIR", out)
        .env("PENUMBRA_ARGS", ARGS)
        .env("SLURM_CPUS_PER_TASK", "1");
    for k in ["SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT", "SLURM_ARRAY_TASK_MIN", "SLURM_ARRAY_TASK_MAX", "PART"] {
        c.env_remove(k);
    }
    if let Some((i, n)) = task {
        c.env("SLURM_ARRAY_TASK_ID", i.to_string()).env("SLURM_ARRAY_TASK_COUNT", n.to_string());
    }
    c.envs(extra.iter().copied());
    c.output().unwrap()
}

#[test]
fn slurm_example_scripts_render_parts_rerun_one_alone_and_merge() {
    let d = tmpdir("slurm");
    for i in [0, 1, 3] {
        let max = "3".to_string();
        ok(sbatch_like(
            "render.sbatch",
            &d,
            Some((i, 4)),
            &[("SLURM_ARRAY_TASK_MIN", "0"), ("SLURM_ARRAY_TASK_MAX", &max)],
        ));
    }
    // The merge names the missing part.
    let o = sbatch_like("merge.sbatch", &d, None, &[]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("part2.exr"), "{}", String::from_utf8_lossy(&o.stderr));
    // Part 2 rerun alone, as the README says: `sbatch --array=2 --export=ALL,PART=2/4`.
    // Without PART, `--part auto` sees a one-task array and refuses it.
    let o =
        sbatch_like("render.sbatch", &d, Some((2, 1)), &[("SLURM_ARRAY_TASK_MIN", "2"), ("SLURM_ARRAY_TASK_MAX", "2")]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("not numbered 0..0"), "{}", String::from_utf8_lossy(&o.stderr));
    ok(sbatch_like("render.sbatch", &d, Some((2, 1)), &[("PART", "2/4")]));
    for i in 0..4 {
        assert!(!d.join(format!("part{i}.ck")).exists(), "the checkpoint of a complete part is removed");
    }
    ok(sbatch_like("merge.sbatch", &d, None, &[]));

    let single = d.join("single.exr");
    let bin = || Command::new(env!("CARGO_BIN_EXE_penumbra"));
    let args: Vec<&str> = ARGS.split(' ').collect();
    ok(bin()
        .arg("render")
        .arg(root().join("scenes/cornell-box.xml"))
        .arg("-o")
        .arg(&single)
        .args(&args)
        .output()
        .unwrap());
    let o = ok(bin().arg("diff").arg(d.join("merged.exr")).arg(&single).args(["--max-rel", "1e-6"]).output().unwrap());
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let line = text.lines().find(|l| l.starts_with("max rel:")).expect("diff prints max rel");
    eprintln!("merged (Slurm example scripts) vs single render: {line}");

    // --max-rel fails for another render.
    let other = d.join("other.exr");
    ok(bin()
        .arg("render")
        .arg(root().join("scenes/cornell-box.xml"))
        .arg("-o")
        .arg(&other)
        .args(["-D", "res=24", "--spp", "8"])
        .args(["--seed", "6"])
        .output()
        .unwrap());
    let o = bin().arg("diff").arg(&other).arg(&single).args(["--max-rel", "1e-6"]).output().unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("above --max-rel"), "{}", String::from_utf8_lossy(&o.stderr));
    fs::remove_dir_all(&d).ok();
}

#[test]
fn slurm_example_scripts_are_valid_bash_with_the_documented_options() {
    for f in ["render.sbatch", "merge.sbatch", "submit.sh"] {
        let p = root().join("examples/slurm").join(f);
        ok(Command::new("bash").arg("-n").arg(&p).output().unwrap());
        assert!(fs::read_to_string(&p).unwrap().starts_with("#!/bin/bash\n"), "{f}: sbatch needs a #! line");
    }
    let render = fs::read_to_string(root().join("examples/slurm/render.sbatch")).unwrap();
    for want in ["#SBATCH --array=0-", "#SBATCH --requeue", "--checkpoint", "--part \"${PART:-auto}\"", "exec "] {
        assert!(render.contains(want), "render.sbatch lacks {want}");
    }
    let submit = fs::read_to_string(root().join("examples/slurm/submit.sh")).unwrap();
    for want in ["--dependency=afterok:", "--kill-on-invalid-dep=yes", "--parsable"] {
        assert!(submit.contains(want), "submit.sh lacks {want}");
    }
}

/// The Kubernetes manifest, parsed with Python's yaml module (`python3` from
/// PATH; .ci/run puts a virtual environment with PyYAML first on PATH).
/// Without the module it is skipped, and fails under CI (`common::skip`).
#[test]
fn kubernetes_indexed_job_parses_and_agrees_with_itself() {
    let script = r#"
import sys, yaml
docs = [d for d in yaml.safe_load_all(open(sys.argv[1])) if d]
by = {(d["kind"], d["metadata"]["name"]): d for d in docs}
parts = by[("Job", "penumbra-parts")]["spec"]
merge = by[("Job", "penumbra-merge")]["spec"]
pvc = by[("PersistentVolumeClaim", "penumbra-renders")]
assert parts["completionMode"] == "Indexed"
n = parts["completions"]
pod = parts["template"]["spec"]
assert pod["restartPolicy"] == "Never"
cmd = " ".join(pod["containers"][0]["command"] + pod["containers"][0]["args"])
assert f"--part auto/{n}" in cmd, cmd
assert "$JOB_COMPLETION_INDEX" in cmd and "--checkpoint /renders/" in cmd, cmd
mcmd = merge["template"]["spec"]["containers"][0]["command"]
assert [a for a in mcmd if a.startswith("/renders/part")] == [f"/renders/part{i}.exr" for i in range(n)], mcmd
for spec in (pod, merge["template"]["spec"]):
    assert spec["volumes"][0]["persistentVolumeClaim"]["claimName"] == pvc["metadata"]["name"]
    assert spec["containers"][0]["volumeMounts"][0]["mountPath"] == "/renders"
assert "ReadWriteMany" in pvc["spec"]["accessModes"]
labels = sorted(d["metadata"]["labels"]["step"] for d in docs)
assert labels == ["merge", "parts", "parts"], labels
print(f"ok: {len(docs)} documents, {n} indexed parts")
"#;
    let yaml = root().join("examples/kubernetes/indexed-job.yaml");
    let probe = Command::new("python3").args(["-c", "import yaml"]).output();
    if !probe.is_ok_and(|o| o.status.success()) {
        return common::skip(
            "kubernetes_indexed_job_parses_and_agrees_with_itself",
            "python3 with the yaml module is not available (pip install pyyaml, or apt-get install python3-yaml)",
        );
    }
    let o = ok(Command::new("python3").arg("-c").arg(script).arg(&yaml).output().unwrap());
    eprintln!("{}", String::from_utf8_lossy(&o.stdout).trim());
}
