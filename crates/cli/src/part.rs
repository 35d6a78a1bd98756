//! `--part I/N`: which slice of the sample indices this process renders, from
//! the command line or from the environment of a Slurm job array or a
//! Kubernetes Indexed Job (`--part auto`, `--part auto/N`).

use anyhow::{anyhow, bail, Result};
use std::ops::Range;

/// Part `index` (0-based) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Part {
    pub index: u32,
    pub count: u32,
}

impl Part {
    /// The sample indices of this part: `[I·spp/N, (I+1)·spp/N)`, so the N
    /// parts together are exactly the samples `0..spp` of one render.
    pub fn samples(&self, spp: u32) -> Range<u32> {
        let at = |i: u32| (i as u64 * spp as u64 / self.count as u64) as u32;
        at(self.index)..at(self.index + 1)
    }
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

fn parse_u32(s: &str, what: &str) -> Result<u32> {
    s.trim().parse::<u32>().map_err(|_| anyhow!("{what} '{s}' is not a non-negative integer"))
}

/// Parses `I/N` (as written in files and on the command line).
pub fn parse_fixed(s: &str) -> Result<Part> {
    let (i, n) = s.split_once('/').ok_or_else(|| anyhow!("--part '{s}' is not of the form I/N, auto or auto/N"))?;
    let p = Part { index: parse_u32(i, "part index")?, count: parse_u32(n, "part count")? };
    if p.count == 0 || p.index >= p.count {
        bail!("--part {s}: the index must be in 0..{} (parts are numbered from 0)", p.count.max(1) - 1);
    }
    Ok(p)
}

/// Parses `--part`: `I/N`, `auto` or `auto/N`; `env` looks up environment
/// variables (a parameter so that tests need not change the process's).
pub fn parse(s: &str, env: &dyn Fn(&str) -> Option<String>) -> Result<Part> {
    let s = s.trim();
    let (auto, n) = match s.split_once('/') {
        Some(("auto", n)) => (true, Some(parse_u32(n, "part count")?)),
        None if s == "auto" => (true, None),
        _ => (false, None),
    };
    if !auto {
        return parse_fixed(s);
    }
    if let Some(id) = env("SLURM_ARRAY_TASK_ID") {
        let id = parse_u32(&id, "SLURM_ARRAY_TASK_ID")?;
        let count = env("SLURM_ARRAY_TASK_COUNT")
            .ok_or_else(|| anyhow!("--part auto: SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not"))?;
        let count = parse_u32(&count, "SLURM_ARRAY_TASK_COUNT")?;
        let num = |k: &str| env(k).and_then(|v| v.trim().parse::<u32>().ok());
        let (min, max, step) = (num("SLURM_ARRAY_TASK_MIN"), num("SLURM_ARRAY_TASK_MAX"), num("SLURM_ARRAY_TASK_STEP"));
        let numbered_0_to_n = id < count
            && !matches!(min, Some(m) if m != 0)
            && !matches!(max, Some(m) if m + 1 != count)
            && !matches!(step, Some(s) if s != 1);
        if !numbered_0_to_n {
            bail!(
                "--part auto: this Slurm job array is not numbered 0..{}: task {id} of {count} tasks \
                 (SLURM_ARRAY_TASK_MIN={}, MAX={}, STEP={}); submit the array as `sbatch --array=0-{}` \
                 (a `%` throttle is fine) or give --part I/N explicitly",
                count.max(1) - 1,
                min.map_or("unset".into(), |v| v.to_string()),
                max.map_or("unset".into(), |v| v.to_string()),
                step.map_or("unset".into(), |v| v.to_string()),
                count.max(1) - 1,
            );
        }
        if let Some(n) = n {
            if n != count {
                bail!("--part auto/{n}: the Slurm job array has {count} tasks, not {n}");
            }
        }
        return Ok(Part { index: id, count });
    }
    if let Some(idx) = env("JOB_COMPLETION_INDEX") {
        let index = parse_u32(&idx, "JOB_COMPLETION_INDEX")?;
        let count = n.ok_or_else(|| {
            anyhow!(
                "--part auto: JOB_COMPLETION_INDEX={index} (a Kubernetes Indexed Job) does not say how many parts \
                 there are: use --part auto/N with N the Job's `completions`"
            )
        })?;
        if index >= count {
            bail!("--part auto/{count}: JOB_COMPLETION_INDEX={index} is not in 0..{}", count - 1);
        }
        return Ok(Part { index, count });
    }
    bail!(
        "--part {s}: neither SLURM_ARRAY_TASK_ID (a Slurm job array) nor JOB_COMPLETION_INDEX \
         (a Kubernetes Indexed Job) is set; give --part I/N explicitly"
    )
}

/// Worker threads: `--threads`, else `SLURM_CPUS_PER_TASK` (the CPUs Slurm
/// granted, not every core of the node), else all cores (`None`).
pub fn threads(arg: Option<usize>, env: &dyn Fn(&str) -> Option<String>) -> Result<Option<usize>> {
    if arg.is_some() {
        return Ok(arg);
    }
    match env("SLURM_CPUS_PER_TASK") {
        Some(v) => {
            let n = v.trim().parse::<usize>().map_err(|_| anyhow!("SLURM_CPUS_PER_TASK='{v}' is not a number"))?;
            Ok(Some(n.max(1)))
        }
        None => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let m: HashMap<String, String> = vars.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        move |k| m.get(k).cloned()
    }

    #[test]
    fn parts_cover_every_sample_once() {
        for (spp, n) in [(16, 4), (17, 4), (5, 5), (1000, 7)] {
            let mut next = 0;
            for i in 0..n {
                let r = Part { index: i, count: n }.samples(spp);
                assert_eq!(r.start, next);
                next = r.end;
            }
            assert_eq!(next, spp);
        }
    }

    #[test]
    fn parses_fixed_and_auto() {
        let none = env(&[]);
        assert_eq!(parse("2/4", &none).unwrap(), Part { index: 2, count: 4 });
        assert!(parse("4/4", &none).is_err());
        assert!(parse("1/0", &none).is_err());
        assert!(parse("x", &none).is_err());
        assert!(parse("auto", &none).unwrap_err().to_string().contains("neither SLURM_ARRAY_TASK_ID"));
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "3"),
            ("SLURM_ARRAY_TASK_STEP", "1"),
        ]);
        assert_eq!(parse("auto", &slurm).unwrap(), Part { index: 2, count: 4 });
        assert!(parse("auto/5", &slurm).is_err());
        // --array=1-4: COUNT 4, MIN 1, MAX 4.
        let shifted = env(&[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "4"),
        ]);
        let e = parse("auto", &shifted).unwrap_err().to_string();
        assert!(e.contains("not numbered 0..3") && e.contains("--array=0-3"), "{e}");
        // --array=0-15:4
        let stepped = env(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "12"),
            ("SLURM_ARRAY_TASK_STEP", "4"),
        ]);
        assert!(parse("auto", &stepped).is_err());
        let k8s = env(&[("JOB_COMPLETION_INDEX", "3")]);
        assert_eq!(parse("auto/8", &k8s).unwrap(), Part { index: 3, count: 8 });
        assert!(parse("auto", &k8s).unwrap_err().to_string().contains("auto/N"));
        assert!(parse("auto/3", &k8s).is_err());
    }

    #[test]
    fn threads_follow_slurm() {
        assert_eq!(threads(None, &env(&[("SLURM_CPUS_PER_TASK", "3")])).unwrap(), Some(3));
        assert_eq!(threads(Some(2), &env(&[("SLURM_CPUS_PER_TASK", "3")])).unwrap(), Some(2));
        assert_eq!(threads(None, &env(&[])).unwrap(), None);
    }
}
