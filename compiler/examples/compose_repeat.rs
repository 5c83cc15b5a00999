//! Composes a scene N times in one process and prints the mean time per composition: a harness
//! for profilers, whose instruction counts (unlike criterion's wall-clock times) do not drift
//! with the machine's load. For example:
//!
//! ```sh
//! cargo build --release -p vrsc --example compose_repeat
//! valgrind --tool=callgrind target/release/examples/compose_repeat \
//!     tests/fixtures/compose/bench_3vol_2lights_4clips/scene.toml 50 [VIEW]
//! ```

// The allocator the `vrsc` binary ships with (see cli/src/main.rs).
#[global_allocator]
static GLOBAL: vrsc_alloc::MiMalloc = vrsc_alloc::MiMalloc;

use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(scene), count) = (args.first(), args.get(1).map(|n| n.parse::<u32>())) else {
        eprintln!("usage: compose_repeat SCENE [COUNT] [VIEW]");
        return ExitCode::from(2);
    };
    let count = match count {
        None => 100,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => {
            eprintln!("COUNT must be a positive integer");
            return ExitCode::from(2);
        }
    };
    let view = args.get(2).map(String::as_str);
    let start = Instant::now();
    for _ in 0..count {
        match vrsc::compose::build::build_scene(scene.as_ref(), view) {
            Ok(built) if !built.diags.has_errors() => drop(std::hint::black_box(built)),
            Ok(_) => {
                eprintln!("{scene} does not compose: run `vrsc build` on it to see why");
                return ExitCode::FAILURE;
            }
            Err(e) => {
                eprintln!("cannot read {scene}: {e}");
                return ExitCode::from(2);
            }
        }
    }
    println!("{count} compositions, {:.3} ms each", start.elapsed().as_secs_f64() * 1e3 / f64::from(count));
    ExitCode::SUCCESS
}
