//! The scale-out recipes in examples/ work as written: each is parsed (the
//! Kubernetes and GitHub Actions YAML by a careful line parser, the Slurm
//! scripts with `bash -n`), and its bake and merge commands are run here
//! with the variables the batch system would set, on a small generated
//! city; the merged file must be the bytes of one bake.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn example(path: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(path);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// A folder with `citypvs` on PATH, a small city as `city.geojson` and the
/// bytes of its one-process bake.
struct Site {
    dir: tempfile::TempDir,
    path: String,
    reference: Vec<u8>,
}

impl Site {
    fn new() -> Site {
        let dir = tempfile::tempdir().unwrap();
        let bin = dir.path().join("bin");
        std::fs::create_dir(&bin).unwrap();
        std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_citypvs"), bin.join("citypvs")).unwrap();
        let path = format!(
            "{}:{}",
            bin.display(),
            std::env::var("PATH").unwrap_or_default()
        );
        let mut site = Site {
            dir,
            path,
            reference: Vec::new(),
        };
        site.sh(
            "citypvs generate --buildings 8 --seed 9 -o city.geojson",
            &[],
        );
        site.sh("citypvs bake city.geojson -o reference.pvs --quiet", &[]);
        site.reference = std::fs::read(site.dir.path().join("reference.pvs")).unwrap();
        site
    }

    fn root(&self) -> &Path {
        self.dir.path()
    }

    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.current_dir(self.root()).env("PATH", &self.path);
        for var in [
            "JOB_COMPLETION_INDEX",
            "SLURM_ARRAY_TASK_ID",
            "CITYPVS_SHARD",
        ] {
            c.env_remove(var);
        }
        c
    }

    fn check(&self, what: &str, out: std::process::Output) {
        assert!(
            out.status.success(),
            "{what}: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }

    /// Run a shell command line in the site with extra variables.
    fn sh(&self, line: &str, env: &[(&str, &str)]) {
        let mut c = self.command("bash");
        c.args(["-euo", "pipefail", "-c", line]);
        for (k, v) in env {
            c.env(k, v);
        }
        self.check(line, c.output().unwrap());
    }

    /// Run an argument vector (a container's `command`) in the site.
    fn exec(&self, argv: &[String], env: &[(&str, &str)]) {
        let mut c = self.command(&argv[0]);
        c.args(&argv[1..]);
        for (k, v) in env {
            c.env(k, v);
        }
        self.check(&argv.join(" "), c.output().unwrap());
    }

    fn assert_merged(&self, file: &str) {
        let merged = std::fs::read(self.root().join(file)).unwrap();
        assert!(merged == self.reference, "{file} differs from one bake");
    }
}

/// The value of the first `key: value` line (trimmed) in `text`.
fn field<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    text.lines()
        .find_map(|l| l.trim().strip_prefix(&format!("{key}:")).map(str::trim))
}

/// Every `command: [...]` flow list, parsed (its items are double-quoted
/// strings, so the flow list is JSON).
fn container_commands(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("command:").map(str::trim))
        .map(|list| serde_json::from_str(list).unwrap_or_else(|e| panic!("{list}: {e}")))
        .collect()
}

#[test]
fn kubernetes_indexed_job_and_merge_job() {
    let site = Site::new();
    let bake = example("kubernetes/bake-job.yaml");
    let merge = example("kubernetes/merge-job.yaml");
    assert_eq!(field(&bake, "kind"), Some("Job"));
    assert_eq!(field(&bake, "completionMode"), Some("Indexed"));
    let n: usize = field(&bake, "completions").unwrap().parse().unwrap();
    assert_eq!(field(&bake, "parallelism"), Some(n.to_string().as_str()));
    // The Job's volume is the site's working directory.
    assert_eq!(field(&bake, "workingDir"), Some("/data"));
    assert_eq!(field(&bake, "mountPath"), Some("/data"));
    assert_eq!(field(&merge, "workingDir"), Some("/data"));
    let bake_cmd = container_commands(&bake);
    assert_eq!(bake_cmd.len(), 1);
    assert!(
        bake_cmd[0].iter().any(|a| a == &format!("auto/{n}")),
        "{bake_cmd:?}"
    );
    for k in 0..n {
        site.exec(&bake_cmd[0], &[("JOB_COMPLETION_INDEX", &k.to_string())]);
    }
    let merge_cmd = container_commands(&merge);
    assert_eq!(merge_cmd.len(), 1);
    site.exec(&merge_cmd[0], &[]);
    let out = merge_cmd[0]
        .iter()
        .skip_while(|a| *a != "-o")
        .nth(1)
        .unwrap();
    site.assert_merged(out);
}

#[test]
fn slurm_array_and_dependent_merge_job() {
    let site = Site::new();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/slurm");
    for script in ["bake.sbatch", "merge.sbatch", "submit.sh"] {
        let out = Command::new("bash")
            .arg("-n")
            .arg(dir.join(script))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{script}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let bake = example("slurm/bake.sbatch");
    let array = field(&bake.replace("#SBATCH --array=", "array:"), "array")
        .unwrap()
        .to_string();
    let (lo, hi) = array.split_once('-').unwrap();
    let (lo, hi): (usize, usize) = (lo.parse().unwrap(), hi.parse().unwrap());
    assert_eq!(lo, 0);
    let shards: usize = field(&bake.replace("SHARDS=", "SHARDS:"), "SHARDS")
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(hi + 1, shards, "--array and SHARDS disagree");
    for k in lo..=hi {
        let mut c = site.command("bash");
        c.arg(dir.join("bake.sbatch"))
            .env("SLURM_ARRAY_TASK_ID", k.to_string())
            .env("CITY", "city.geojson");
        site.check("bake.sbatch", c.output().unwrap());
    }
    let mut c = site.command("bash");
    c.arg(dir.join("merge.sbatch")).env("CITY", "city.geojson");
    site.check("merge.sbatch", c.output().unwrap());
    site.assert_merged("city.pvs");

    // submit.sh makes the merge wait for the whole array: a stand-in sbatch
    // records its arguments.
    let fake = site.root().join("fake");
    std::fs::create_dir(&fake).unwrap();
    let log = site.root().join("sbatch.log");
    let stub = format!(
        "#!/bin/bash\necho \"$*\" >> {}\necho '4242;cluster'\n",
        log.display()
    );
    std::fs::write(fake.join("sbatch"), stub).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(fake.join("sbatch"), std::fs::Permissions::from_mode(0o755)).unwrap();
    let mut c = site.command("bash");
    c.arg(dir.join("submit.sh"))
        .env("PATH", format!("{}:{}", fake.display(), site.path));
    site.check("submit.sh", c.output().unwrap());
    let calls: Vec<String> = std::fs::read_to_string(&log)
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    assert_eq!(
        calls,
        vec![
            "--parsable bake.sbatch",
            "--dependency=afterok:4242 merge.sbatch"
        ]
    );
}

/// A GitHub Actions job: its matrix values and its steps (each step's
/// `run` line and `env` entries, `with` entries).
#[derive(Default, Debug)]
struct Job {
    needs: Option<String>,
    matrix: BTreeMap<String, Vec<String>>,
    steps: Vec<Step>,
}

#[derive(Default, Debug)]
struct Step {
    run: Option<String>,
    env: Vec<(String, String)>,
    with: BTreeMap<String, String>,
}

/// A line parser for the workflow's subset of YAML: jobs at indent 2,
/// job keys at 4, matrix entries at 8 (flow lists), steps as `- ` at 6 with
/// their keys at 8 and `env`/`with` entries at 10.
fn parse_workflow(text: &str) -> BTreeMap<String, Job> {
    let mut jobs: BTreeMap<String, Job> = BTreeMap::new();
    let mut in_jobs = false;
    let mut job: Option<String> = None;
    let mut block = String::new(); // the step key whose entries follow (env, with)
    let mut in_matrix = false;
    for raw in text.lines() {
        let line = raw.trim_end();
        if line.trim().is_empty() || line.trim_start().starts_with('#') {
            continue;
        }
        let indent = line.len() - line.trim_start().len();
        let body = line.trim_start();
        if indent == 0 {
            in_jobs = body == "jobs:";
            continue;
        }
        if !in_jobs {
            continue;
        }
        match indent {
            2 => {
                let name = body.strip_suffix(':').expect("job name").to_string();
                jobs.insert(name.clone(), Job::default());
                job = Some(name);
                in_matrix = false;
            }
            4 => {
                let j = jobs.get_mut(job.as_ref().unwrap()).unwrap();
                if let Some(n) = body.strip_prefix("needs:") {
                    j.needs = Some(n.trim().to_string());
                }
                in_matrix = false;
            }
            6 if body == "matrix:" => in_matrix = true,
            6 if body.starts_with("- ") => {
                let j = jobs.get_mut(job.as_ref().unwrap()).unwrap();
                j.steps.push(Step::default());
                block.clear();
                step_key(j.steps.last_mut().unwrap(), &body[2..], &mut block);
            }
            8 if in_matrix => {
                let (k, v) = body.split_once(':').unwrap();
                let values: Vec<serde_json::Value> = serde_json::from_str(v.trim()).unwrap();
                let j = jobs.get_mut(job.as_ref().unwrap()).unwrap();
                j.matrix.insert(
                    k.to_string(),
                    values.iter().map(|v| v.to_string()).collect(),
                );
            }
            8 => {
                let j = jobs.get_mut(job.as_ref().unwrap()).unwrap();
                step_key(j.steps.last_mut().unwrap(), body, &mut block);
            }
            10 => {
                let j = jobs.get_mut(job.as_ref().unwrap()).unwrap();
                let step = j.steps.last_mut().unwrap();
                let (k, v) = body.split_once(':').unwrap();
                let (k, v) = (k.to_string(), v.trim().to_string());
                match block.as_str() {
                    "env" => step.env.push((k, v)),
                    "with" => {
                        step.with.insert(k, v);
                    }
                    other => panic!("unexpected entry under {other}: {line}"),
                }
            }
            _ => {}
        }
    }
    jobs
}

fn step_key(step: &mut Step, body: &str, block: &mut String) {
    let (k, v) = body.split_once(':').unwrap();
    match (k, v.trim()) {
        ("run", cmd) => step.run = Some(cmd.to_string()),
        (key, "") => *block = key.to_string(),
        _ => {}
    }
}

#[test]
fn github_actions_matrix_of_shards_then_a_merge_job() {
    let site = Site::new();
    let jobs = parse_workflow(&example("github-actions/bake-pvs.yml"));
    let bake = &jobs["bake"];
    let merge = &jobs["merge"];
    assert_eq!(merge.needs.as_deref(), Some("bake"));
    let shards = &bake.matrix["shard"];
    assert_eq!(shards.len(), 4);
    let subst = |s: &str, k: &str| s.replace("${{ matrix.shard }}", k);
    let runs_citypvs = |s: &&Step| s.run.as_deref().is_some_and(|r| r.starts_with("citypvs "));
    let mut uploaded: Vec<PathBuf> = Vec::new();
    for k in shards {
        for step in &bake.steps {
            if runs_citypvs(&step) {
                let env: Vec<(String, String)> = step
                    .env
                    .iter()
                    .map(|(n, v)| (n.clone(), subst(v, k)))
                    .collect();
                assert!(
                    env.iter().any(|(n, v)| n == "CITYPVS_SHARD" && v == k),
                    "{env:?}"
                );
                let env: Vec<(&str, &str)> =
                    env.iter().map(|(n, v)| (n.as_str(), v.as_str())).collect();
                site.sh(&subst(step.run.as_ref().unwrap(), k), &env);
            }
            if let Some(path) = step.with.get("path") {
                uploaded.push(site.root().join(subst(path, k)));
            }
        }
    }
    assert_eq!(uploaded.len(), 4);
    for p in &uploaded {
        assert!(
            p.exists(),
            "the upload step names {} but no such file was baked",
            p.display()
        );
    }
    let merges: Vec<&Step> = merge.steps.iter().filter(runs_citypvs).collect();
    assert_eq!(merges.len(), 1);
    site.sh(merges[0].run.as_ref().unwrap(), &[]);
    let out = merges[0]
        .run
        .as_ref()
        .unwrap()
        .split_whitespace()
        .skip_while(|a| *a != "-o")
        .nth(1)
        .unwrap();
    site.assert_merged(out);
}
