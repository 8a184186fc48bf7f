//! A build split into a plan, shards and a merge writes the same bytes as
//! the single-process build, in any shard order, and redoes only what is
//! missing or corrupt.

use std::path::{Path, PathBuf};

use gigawalk_preprocess::shards::{self, ShardRun};
use gigawalk_preprocess::{preprocess, NoProgress, Params};
use gigawalk_procgen::{generate, Kind};

/// A plant and a machine floor in two files.
fn model_files(dir: &Path) -> Vec<PathBuf> {
    let a = dir.join("plant.glb");
    let b = dir.join("floor/machines.glb");
    std::fs::create_dir_all(dir.join("floor")).unwrap();
    std::fs::write(&a, generate(Kind::Plant, 30_000, 1, 2).glb_bytes()).unwrap();
    std::fs::write(&b, generate(Kind::Machine, 20_000, 2, 2).glb_bytes()).unwrap();
    vec![a, dir.join("floor")]
}

fn single(inputs: &[PathBuf], source: &str, out: &Path) -> Vec<u8> {
    let model = gigawalk_import::import_all(inputs, &mut |_, _, _| {}).unwrap();
    preprocess(&model, &Params::default(), out, source, &NoProgress).unwrap();
    std::fs::read(out).unwrap()
}

#[test]
fn shards_in_any_order_and_a_redone_shard_give_the_single_process_bytes() {
    let t = tempfile::tempdir().unwrap();
    let inputs = model_files(t.path());
    let source = "plant.glb floor";
    let reference = single(&inputs, source, &t.path().join("single.gwk"));

    let work = t.path().join("work");
    let params = Params::default();
    let plan = shards::make_plan(&inputs, source, &params, 8_000, &work, &NoProgress).unwrap();
    let n = plan.shards.len();
    assert!(n >= 4, "{n} shards");
    assert_eq!(
        plan.triangles,
        plan.shards.iter().map(|s| s.triangles).sum::<u64>()
    );
    // The same plan again is found, not remade.
    let again = shards::make_plan(&inputs, source, &params, 8_000, &work, &NoProgress).unwrap();
    assert_eq!(again, plan);
    assert_eq!(shards::unfinished_shards(&work, &plan).len(), n);

    // Shards in a shuffled order, one of them twice.
    let mut order: Vec<usize> = (0..n).rev().collect();
    order.swap(0, n / 2);
    for &k in &order {
        assert_eq!(
            shards::run_shard(&work, k, None, &NoProgress).unwrap(),
            ShardRun::Made
        );
    }
    assert_eq!(
        shards::run_shard(&work, 0, None, &NoProgress).unwrap(),
        ShardRun::AlreadyDone
    );
    assert!(shards::unfinished_shards(&work, &plan).is_empty());
    let out = t.path().join("merged.gwk");
    let mut redone = Vec::new();
    shards::merge(&work, &out, None, &NoProgress, &mut |k, _| redone.push(k)).unwrap();
    assert!(redone.is_empty());
    assert!(
        std::fs::read(&out).unwrap() == reference,
        "merged scene differs"
    );

    // A corrupt shard and a missing one: the merge makes them again.
    let p1 = shards::shard_path(&work, &plan, 1);
    let mut bytes = std::fs::read(&p1).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    std::fs::write(&p1, bytes).unwrap();
    std::fs::remove_file(shards::shard_path(&work, &plan, n - 1)).unwrap();
    assert_eq!(shards::unfinished_shards(&work, &plan), vec![1, n - 1]);
    let out2 = t.path().join("merged2.gwk");
    shards::merge(&work, &out2, None, &NoProgress, &mut |k, _| redone.push(k)).unwrap();
    assert_eq!(redone, vec![1, n - 1]);
    assert!(
        std::fs::read(&out2).unwrap() == reference,
        "redone scene differs"
    );

    // The model's spill cut short (or gone): made again from the inputs,
    // the same scene.
    let spill = shards::spill_path(&work, &plan);
    let len = std::fs::metadata(&spill).unwrap().len();
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(&spill)
        .unwrap();
    f.set_len(len / 2).unwrap();
    drop(f);
    std::fs::remove_file(shards::shard_path(&work, &plan, 0)).unwrap();
    let out3 = t.path().join("merged3.gwk");
    shards::merge(&work, &out3, Some(64 << 20), &NoProgress, &mut |_, _| {}).unwrap();
    assert!(std::fs::read(&out3).unwrap() == reference, "remade spill");
    assert_eq!(std::fs::metadata(&spill).unwrap().len(), len);
}

#[test]
fn a_changed_input_or_other_parameters_are_refused() {
    let t = tempfile::tempdir().unwrap();
    let inputs = model_files(t.path());
    let work = t.path().join("work");
    let params = Params::default();
    let plan = shards::make_plan(&inputs, "m", &params, 20_000, &work, &NoProgress).unwrap();
    // Other parameters, or another shard size, under the same directory.
    let other = Params {
        lod_ratio: 0.4,
        ..Params::default()
    };
    let e = shards::make_plan(&inputs, "m", &other, 20_000, &work, &NoProgress).unwrap_err();
    assert!(
        e.to_string().contains("holds a plan for other inputs"),
        "{e}"
    );
    let e = shards::make_plan(&inputs, "m", &params, 10_000, &work, &NoProgress).unwrap_err();
    assert!(matches!(e, shards::ShardError::OtherPlan { .. }), "{e}");
    // An input changed after the plan: shards and the merge refuse it.
    let plant = t.path().join("plant.glb");
    let mut bytes = std::fs::read(&plant).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x20;
    std::fs::write(&plant, bytes).unwrap();
    let e = shards::run_shard(&work, 0, None, &NoProgress).unwrap_err();
    assert!(matches!(e, shards::ShardError::InputChanged { .. }), "{e}");
    assert!(e.to_string().contains("plant.glb"), "{e}");
    let e = shards::merge(
        &work,
        &t.path().join("x.gwk"),
        None,
        &NoProgress,
        &mut |_, _| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("plant.glb"), "{e}");
    assert!(!t.path().join("x.gwk").exists());
    // A shard the plan does not have.
    let e = shards::run_shard(&work, plan.shards.len(), None, &NoProgress).unwrap_err();
    assert!(matches!(e, shards::ShardError::NoSuchShard { .. }), "{e}");
    // A plan file that is not one.
    std::fs::write(work.join(shards::PLAN_FILE), "{\"format\": 3}").unwrap();
    let e = shards::run_shard(&work, 0, None, &NoProgress).unwrap_err();
    assert!(matches!(e, shards::ShardError::BadPlan { .. }), "{e}");
}
