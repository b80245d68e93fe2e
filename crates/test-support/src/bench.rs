//! The command line of a measurement harness: a bench target with `harness = false` that
//! prints a table rather than running criterion.
//!
//! `cargo bench` runs such a target with `--bench` appended to its arguments;
//! `cargo test --benches` and `cargo test --all-targets` build and run it too, without that
//! flag. A measurement is no test, so a harness measures only when the flag is there.

/// The bench's command line (the program first, as in [`std::env::args`]) without the
/// `--bench` flag that `cargo bench` appends; `None` when `cargo bench` did not run it, after
/// printing ``a measurement: run it with `USAGE` `` on standard error.
///
/// A harness's `main` starts with it and returns, measuring nothing and exiting 0, on `None`:
///
/// ```
/// use keycomp_test_support::bench_args;
///
/// let Some(args) = bench_args("cargo bench -p keycomp-index --bench index_scale -- [SIZES]")
/// else {
///     return; // here: this example is not run by `cargo bench`
/// };
/// let sizes = args.get(1);
/// ```
pub fn bench_args(usage: &str) -> Option<Vec<String>> {
    let args = without_bench_flag(std::env::args());
    if args.is_none() {
        eprintln!("a measurement: run it with `{usage}`");
    }
    args
}

/// The number after `flag` in `args` (`--cases 100`), both removed from `args`; `None` when
/// the flag is absent, an error naming the flag when its value is missing or not a `T`.
///
/// ```
/// use keycomp_test_support::take_number;
///
/// let mut args = vec!["--cases".to_string(), "12".to_string(), "dir".to_string()];
/// assert_eq!(take_number::<usize>(&mut args, "--cases"), Ok(Some(12)));
/// assert_eq!(args, ["dir"]);
/// assert_eq!(take_number::<usize>(&mut args, "--seed"), Ok(None));
/// ```
pub fn take_number<T: std::str::FromStr>(
    args: &mut Vec<String>,
    flag: &str,
) -> Result<Option<T>, String> {
    let Some(i) = args.iter().position(|a| a == flag) else {
        return Ok(None);
    };
    let value = args
        .get(i + 1)
        .and_then(|v| v.parse().ok())
        .ok_or(format!("{flag} needs a number"))?;
    args.drain(i..i + 2);
    Ok(Some(value))
}

/// `args` without the `--bench` flags, or `None` when there is none.
fn without_bench_flag(args: impl IntoIterator<Item = String>) -> Option<Vec<String>> {
    let args: Vec<String> = args.into_iter().collect();
    let under_cargo_bench = args.iter().any(|a| a == "--bench");
    under_cargo_bench.then(|| args.into_iter().filter(|a| a != "--bench").collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(args: &[&str]) -> Vec<String> {
        args.iter().map(|a| a.to_string()).collect()
    }

    #[test]
    fn a_flag_s_number_is_taken_out_and_a_bad_one_named() {
        let mut args = strings(&["a", "--n", "7", "b"]);
        assert_eq!(take_number::<u64>(&mut args, "--n"), Ok(Some(7)));
        assert_eq!(args, strings(&["a", "b"]));
        let mut args = strings(&["--n", "x"]);
        assert_eq!(
            take_number::<u64>(&mut args, "--n"),
            Err("--n needs a number".to_string())
        );
        let mut args = strings(&["--n"]);
        assert!(take_number::<u64>(&mut args, "--n").is_err());
    }

    #[test]
    fn cargo_bench_s_flag_is_removed_wherever_it_is() {
        assert_eq!(
            without_bench_flag(strings(&["prog", "1000,10000", "-", "--bench"])),
            Some(strings(&["prog", "1000,10000", "-"]))
        );
        assert_eq!(
            without_bench_flag(strings(&["prog", "--bench", "dir"])),
            Some(strings(&["prog", "dir"]))
        );
        assert_eq!(
            without_bench_flag(strings(&["prog", "--bench"])),
            Some(strings(&["prog"]))
        );
    }

    #[test]
    fn without_the_flag_nothing_is_measured() {
        // `cargo test --benches`, with and without arguments after `--`
        assert_eq!(without_bench_flag(strings(&["prog"])), None);
        assert_eq!(without_bench_flag(strings(&["prog", "mesh.off"])), None);
        // a look-alike is no flag
        assert_eq!(without_bench_flag(strings(&["prog", "--benches"])), None);
    }

    #[test]
    fn a_test_binary_is_not_run_by_cargo_bench() {
        assert_eq!(bench_args("cargo bench -p keycomp-test-support"), None);
    }
}
