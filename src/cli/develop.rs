//! `fslcal develop`: raw photos to PNGs for people and other tools, a season at a time.

use super::outputs::{self, Input, Output};
use super::progress;
use crate::atomic_file::write_atomically;
use crate::photo::raw::develop::{developed_rgb8, for_each_row, write_row, GreyWorld, Order, ToneCurve};
use crate::photo::raw::RawFrame;
use anyhow::{bail, Context};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Develop raw photos (Olympus ORF) to PNG with the thesis's grey-world colour balance.
///
/// Unreadable files are reported and skipped; the exit code is non-zero if any failed.
/// Memory stays bounded whatever the number of photos: at most `--jobs` photos are in
/// flight (about 100 MB each for a TG-6 raw at 8 bits).
#[derive(clap::Args, Debug)]
pub struct DevelopArgs {
    /// Folder for the PNGs (created if missing); each is named after its raw file.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,

    /// Write 16 bits per channel instead of 8.
    #[arg(long = "16bit")]
    sixteen_bit: bool,

    /// Photos developed at once, 1 to 64 (default: one per core; never more than the raws).
    #[arg(long, value_name = "N", value_parser = super::parse::jobs)]
    jobs: Option<usize>,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,

    /// Raw photos.
    #[arg(required = true, value_name = "RAW")]
    raws: Vec<PathBuf>,
}

/// One photo's outcome.
struct Developed {
    out: PathBuf,
    gains: [f32; 3],
}

/// Develops one raw to `out_dir`, returning where it went.
pub fn develop_one(raw: &Path, out_dir: &Path, sixteen_bit: bool) -> anyhow::Result<(PathBuf, [f32; 3])> {
    let frame = RawFrame::read(raw)?;
    let balance = GreyWorld::of(&frame);
    let (w, h) = (frame.width as u32, frame.height as u32);
    let out = png_path(raw, out_dir);
    let mut png = Vec::new();
    {
        let encoder = image::codecs::png::PngEncoder::new_with_quality(
            &mut png,
            image::codecs::png::CompressionType::Fast,
            image::codecs::png::FilterType::Sub,
        );
        use image::ImageEncoder;
        if sixteen_bit {
            // The encoder takes native-endian samples; written straight into its buffer, no copy.
            let tone = ToneCurve::srgb(u16::MAX);
            let stride = frame.width * 3;
            let mut pixels = vec![[0u8; 2]; stride * frame.height];
            for_each_row(&frame, |y, row| {
                write_row(
                    row,
                    balance.gains,
                    &tone,
                    Order::Rgb,
                    &mut pixels[y * stride..(y + 1) * stride],
                    u16::to_ne_bytes,
                )
            });
            drop(frame);
            encoder.write_image(pixels.as_flattened(), w, h, image::ExtendedColorType::Rgb16)
        } else {
            let pixels = developed_rgb8(&frame, &balance);
            drop(frame);
            encoder.write_image(&pixels, w, h, image::ExtendedColorType::Rgb8)
        }
        .with_context(|| format!("{}: cannot encode the PNG", raw.display()))?;
    }
    outputs::say_if_replacing(&out);
    write_atomically(&out, &png).with_context(|| format!("{}: cannot write", out.display()))?;
    Ok((out, balance.gains))
}

/// Where the PNG of `raw` goes in `out_dir`.
fn png_path(raw: &Path, out_dir: &Path) -> PathBuf {
    let stem = raw.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "photo".into());
    out_dir.join(format!("{stem}.png"))
}

pub fn run(args: DevelopArgs) -> anyhow::Result<ExitCode> {
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the output folder", args.out.display()))?;
    let mut seen = std::collections::HashSet::new();
    for r in &args.raws {
        if !seen.insert(r.file_stem().map(|s| s.to_owned())) {
            bail!("{}: two raws share this name; their PNGs would overwrite each other", r.display());
        }
    }
    let pngs: Vec<PathBuf> = args.raws.iter().map(|r| png_path(r, &args.out)).collect();
    let inputs: Vec<Input> = args.raws.iter().map(|r| Input::new("raw", r)).collect();
    let outs: Vec<Output> = pngs.iter().map(|p| Output::file("--out", p)).collect();
    outputs::check(&inputs, &outs, false)?;
    let jobs = args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    // A thread per photo at most: more would only wait (and each is a stack).
    let jobs = jobs.clamp(1, args.raws.len().max(1));
    // A pool of `jobs` threads, each developing one photo at a time: memory is bounded by
    // the pool, not by the batch.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs).build().context("cannot start worker threads")?;
    let bar = progress::bar(args.raws.len(), "raws", args.json);
    let started = Instant::now();
    let results: Vec<anyhow::Result<Developed>> = pool.install(|| {
        use rayon::prelude::*;
        args.raws
            .par_iter()
            .with_max_len(1)
            .map(|raw| {
                let r = develop_one(raw, &args.out, args.sixteen_bit).map(|(out, gains)| Developed { out, gains });
                if let Err(e) = &r {
                    bar.suspend(|| eprintln!("fslcal: skipped: {}", super::error_line(e)));
                }
                bar.inc(1);
                r
            })
            .collect()
    });
    bar.finish_and_clear();
    let elapsed = started.elapsed().as_secs_f64();
    let failed: Vec<String> = results.iter().filter_map(|r| r.as_ref().err().map(super::error_line)).collect();
    let done = results.len() - failed.len();
    if args.json {
        let photos: Vec<_> = args
            .raws
            .iter()
            .zip(&results)
            .map(|(raw, r)| match r {
                Ok(d) => json!({"raw": raw.display().to_string(), "png": d.out.display().to_string(), "grey_world_gains": d.gains}),
                Err(e) => json!({"raw": raw.display().to_string(), "error": super::error_line(e)}),
            })
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({
                "developed": done, "failed": failed.len(), "bits": if args.sixteen_bit { 16 } else { 8 },
                "seconds": elapsed, "photos": photos,
            }))?
        );
    } else {
        println!(
            "developed {done} of {} raws to {} ({}-bit PNG) in {elapsed:.1} s ({:.2} s per photo, {jobs} at a time); failed {}",
            results.len(),
            args.out.display(),
            if args.sixteen_bit { 16 } else { 8 },
            elapsed / results.len().max(1) as f64,
            failed.len()
        );
    }
    Ok(if failed.is_empty() { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}
