#![allow(unsafe_code)] // Reads the host stack pointer and paints the stack: the only way to estimate stack use.
//! An estimate of the RAM the firmware needs, made on the host: the size of its whole state,
//! and the stack its deepest paths use in the *host's* x86_64 build, measured by painting the
//! host thread's stack (fill it with a pattern, run the path, find the lowest byte it
//! overwrote; x86_64 only, where CI runs). See the figures with
//! `cargo test --release -p firmware-sim --test memory -- --nocapture`.
//!
//! Nothing here runs on the target. The host's stack is a proxy for the Cortex-M4's: that
//! build has 4-byte pointers but soft-float f64 and different inlining, so every figure is
//! an estimate, and the assertions only bound it (16 KiB for each path) rather than hold
//! it to a tight budget.

#![cfg(target_arch = "x86_64")]

mod common;

use common::*;
use embedded_graphics::pixelcolor::BinaryColor;
use embedded_graphics::prelude::*;
use firmware_sim::{screens, Event, Firmware};
use fslcal_core::unit_file;
use std::hint::black_box;

/// Bytes below the measuring frame that get painted: far more than any path needs.
const PAINT_BYTES: usize = 256 * 1024;
/// Left unpainted below the stack pointer: x86_64's red zone, which the measuring frame may
/// use without moving the stack pointer. Added back to every figure, so they err high.
const RED_ZONE: usize = 128;

/// Peak host stack of a call to `f` in bytes, from the caller's stack pointer down: the
/// estimate of the target's.
fn host_stack_estimate<F: Fn() + Send + Sync + 'static>(f: F) -> usize {
    let g: Box<dyn Fn() + Send + Sync> = Box::new(f);
    std::thread::Builder::new().stack_size(4 * PAINT_BYTES).spawn(move || paint_and_run(&*g)).unwrap().join().unwrap()
}

#[inline(always)]
fn stack_pointer() -> usize {
    let sp: usize;
    // SAFETY: reads a register, touches no memory.
    unsafe { std::arch::asm!("mov {}, rsp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

#[inline(never)]
fn paint_and_run(f: &dyn Fn()) -> usize {
    let top = stack_pointer() - RED_ZONE;
    let bottom = top - PAINT_BYTES;
    let mut deepest = top;
    // Two patterns, so that a path that happens to store the pattern byte is still seen.
    for pattern in [0xA5u8, 0x5A] {
        for addr in bottom..top {
            // SAFETY: this thread's stack is 4 * PAINT_BYTES; [bottom, top) lies below the
            // live frames and above the guard page, and no other thread touches it.
            unsafe { std::ptr::write_volatile(addr as *mut u8, pattern) };
        }
        black_box(f)();
        // SAFETY: as above; the bytes are plain u8 in mapped stack memory.
        let lowest = (bottom..top).find(|&addr| unsafe { std::ptr::read_volatile(addr as *const u8) } != pattern);
        deepest = deepest.min(lowest.unwrap_or(top));
    }
    top - deepest + RED_ZONE
}

#[inline(never)]
fn uses_an_array_of(bytes: usize) {
    let mut a = [0u8; 8192];
    for (i, b) in a[..bytes].iter_mut().enumerate() {
        *b = i as u8;
    }
    black_box(&mut a);
}

/// A 128x64 1-bit framebuffer, as the firmware would keep for an SSD1306-class panel.
struct Framebuffer([u8; 128 * 64 / 8]);

impl OriginDimensions for Framebuffer {
    fn size(&self) -> Size {
        Size::new(128, 64)
    }
}

impl DrawTarget for Framebuffer {
    type Color = BinaryColor;
    type Error = core::convert::Infallible;
    fn draw_iter<I: IntoIterator<Item = Pixel<BinaryColor>>>(&mut self, pixels: I) -> Result<(), Self::Error> {
        for Pixel(p, c) in pixels {
            if (0..128).contains(&p.x) && (0..64).contains(&p.y) {
                let (i, bit) = ((p.y / 8 * 128 + p.x) as usize, p.y % 8);
                self.0[i] = (self.0[i] & !(1 << bit)) | ((c.is_on() as u8) << bit);
            }
        }
        Ok(())
    }
}

#[test]
fn host_stack_painting_measures_a_known_array() {
    let used = host_stack_estimate(|| uses_an_array_of(4096));
    println!("probe (host stack): a function with an 8 KiB array, its lowest 4 KiB written: {used} bytes");
    // The lowest byte written is the array's first, 8 KiB plus a return address and a few
    // saved registers below the caller's stack pointer.
    assert!((8192..8192 + 256).contains(&used), "{used}");
    let empty = host_stack_estimate(|| {});
    println!("probe (host stack): an empty closure: {empty} bytes");
    assert!(empty <= RED_ZONE + 64, "{empty}");
}

#[test]
fn firmware_state_and_host_stack_estimate_fit_a_cortex_m4() {
    let state = size_of::<Firmware>();
    println!(
        "size_of::<Firmware>() on the host = {state} bytes (the whole state: file buffer {} B, calibration {} B; the target's layout differs)",
        unit_file::MAX_FILE_BYTES,
        size_of::<firmware_sim::Calibration>()
    );
    assert!(state < 16 * 1024, "{state}");

    let file = good_file();
    let key = unit_file::public_key(&unit_file::EXAMPLE_SECRET_KEY);
    let f1 = file.clone();
    let verify = host_stack_estimate(move || {
        black_box(unit_file::verify(black_box(&f1), &[key]).is_ok());
    });
    let f0 = file.clone();
    let decode = host_stack_estimate(move || {
        black_box(unit_file::SignedUnitFile::decode(black_box(&f0)).is_ok());
    });
    let parsed = unit_file::SignedUnitFile::decode(&file).unwrap();
    let (signed, signer, signature) = (file[..file.len() - 64].to_vec(), parsed.signer, parsed.signature);
    let ed25519 = host_stack_estimate(move || {
        use ed25519_dalek::{Signature, VerifyingKey};
        let key = VerifyingKey::from_bytes(black_box(&signer)).unwrap();
        black_box(key.verify_strict(black_box(&signed), &Signature::from_bytes(&signature)).is_ok());
    });
    let f2 = file.clone();
    let open = host_stack_estimate(move || {
        black_box(firmware_sim::unit_file::open(black_box(&f2), "FSL-03", trusted()).is_ok());
    });
    let f3 = file.clone();
    let load = host_stack_estimate(move || {
        let mut fw = firmware();
        fw.handle(black_box(Event::LoadFile(&f3)));
        black_box(&fw);
    });
    // The dot and draw paths on a firmware that already holds the file, so that the load's
    // deeper stack does not mask theirs.
    let loaded = || {
        let mut fw = firmware();
        fw.handle(Event::LoadFile(&good_file()));
        fw.handle(Event::Press(firmware_sim::Button::Next));
        std::sync::Mutex::new(fw)
    };
    let fw = loaded();
    let dot = host_stack_estimate(move || {
        let mut fw = fw.lock().unwrap();
        fw.handle(black_box(Event::Dot { u_px: 1986.0, v_px: 1432.7 }));
    });
    let fw = loaded();
    let no_fix_dot = host_stack_estimate(move || {
        // No fix: the drift monitor searches the beam's image instead.
        fw.lock().unwrap().handle(black_box(Event::Dot { u_px: 2250.0, v_px: 1480.0 }));
    });
    let fw = loaded();
    fw.lock().unwrap().handle(Event::Dot { u_px: 1986.0, v_px: 1432.7 });
    let fb = std::sync::Mutex::new(Box::new(Framebuffer([0; 1024])));
    let draw = host_stack_estimate(move || {
        screens::draw(&fw.lock().unwrap(), &mut **fb.lock().unwrap()).unwrap();
    });
    println!("host stack (estimate for the target), decode only (SignedUnitFile::decode): {decode} bytes");
    println!("host stack (estimate for the target), ed25519 verify_strict alone: {ed25519} bytes");
    println!("host stack (estimate for the target), decode + verify (fslcal_core::unit_file::verify): {verify} bytes");
    println!("host stack (estimate for the target), firmware_sim::unit_file::open (verify + unit check): {open} bytes");
    println!("host stack (estimate for the target), Firmware::handle(LoadFile): {load} bytes");
    println!(
        "host stack (estimate for the target), Firmware::handle(Dot) with a fix (distance, sigma, drift): {dot} bytes"
    );
    println!("host stack (estimate for the target), Firmware::handle(Dot) without a fix (beam-image search): {no_fix_dot} bytes");
    println!(
        "host stack (estimate for the target), screens::draw of the live screen into a 1 KiB framebuffer: {draw} bytes"
    );
    let deepest = [decode, verify, open, load, dot, no_fix_dot, draw].into_iter().max().unwrap();
    println!(
        "RAM estimate from the host build: state {state} + framebuffer 1024 + deepest host stack {deepest} = {} bytes",
        state + 1024 + deepest
    );
    for (what, bytes) in
        [("verify", verify), ("open", open), ("load", load), ("dot", dot), ("no-fix dot", no_fix_dot), ("draw", draw)]
    {
        assert!(bytes > 256, "{what}: {bytes} bytes of host stack is implausibly little: the probe is broken");
        assert!(bytes < 16 * 1024, "{what}: {bytes} bytes of host stack, the estimate for the target, over 16 KiB");
    }
}
