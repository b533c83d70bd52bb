//! `cargo bench --bench measure_batch`: `fslcal measure` over a dive of rendered 4000x3000
//! fish photos, end to end as a coordinator runs it (process start, calibration, photo
//! headers, masks decoded and their end points found, lengths, summary). Prints photos per
//! second for the mask path and the label path; asserts nothing about time.

#[path = "../tests/common/mod.rs"]
mod common;

use std::process::Command;
use std::time::Instant;

fn main() {
    // `cargo test --benches` runs this too; keep that quick.
    let full = std::env::args().any(|a| a == "--bench");
    let copies = if full { 50 } else { 2 };
    eprintln!("rendering fish (not timed)...");
    let set = common::fish_set("bench-measure", 4, 5);
    // A dive of `4 * copies` photos: distinct copies of each rendered photo, its mask linked.
    let dive = set.dir.join("dive");
    let _ = std::fs::remove_dir_all(&dive);
    std::fs::create_dir_all(dive.join("masks")).unwrap();
    let (mut photos, mut dots, mut labels) =
        (Vec::new(), String::from("file,x,y\n"), String::from("photo,head_x,head_y,tail_x,tail_y,dot_x,dot_y\n"));
    for c in 0..copies {
        for (i, (p, t)) in set.photos.iter().zip(&set.truths).enumerate() {
            let name = format!("dive_{c:03}_{i}");
            let photo = dive.join(format!("{name}.jpg"));
            common::distinct_copy(p, &photo, c);
            common::link(
                &set.dir.join("masks").join(p.file_stem().unwrap()).with_extension("png"),
                &dive.join("masks").join(format!("{name}.png")),
            );
            let d = t.dot.as_ref().unwrap().pixel;
            dots += &format!("{name}.jpg,{},{}\n", d[0], d[1]);
            labels += &format!(
                "{name}.jpg,{},{},{},{},{},{}\n",
                t.snout_px[0], t.snout_px[1], t.fork_px[0], t.fork_px[1], d[0], d[1]
            );
            photos.push(photo.display().to_string());
        }
    }
    std::fs::write(dive.join("dots.csv"), dots).unwrap();
    std::fs::write(dive.join("labels.csv"), labels).unwrap();
    let cal = set.cal.display().to_string();
    let runs: [(&str, Vec<String>); 2] = [
        (
            "masks",
            vec![
                "--masks".into(),
                dive.join("masks").display().to_string(),
                "--dots".into(),
                dive.join("dots.csv").display().to_string(),
            ],
        ),
        ("labels", vec!["--labels".into(), dive.join("labels.csv").display().to_string()]),
    ];
    for (what, extra) in runs {
        let mut args = vec!["measure".to_string(), "--cal".into(), cal.clone(), "--json".into()];
        args.extend(extra);
        args.extend(photos.iter().cloned());
        let t = Instant::now();
        let out = Command::new(env!("CARGO_BIN_EXE_fslcal")).args(&args).output().expect("run fslcal");
        let secs = t.elapsed().as_secs_f64();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        println!(
            "measure --{what}: {} photos (4000x3000) in {secs:.2} s: {:.1} photos/s, {} of {} fish measured, on {} threads",
            photos.len(),
            photos.len() as f64 / secs,
            v["measured"],
            v["total"],
            rayon::current_num_threads()
        );
    }
}
