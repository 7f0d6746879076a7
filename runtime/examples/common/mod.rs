//! Command-line flags shared by the runtime's examples: `--seconds S`, `--out PATH`, `--help`.

/// The flags of one example run.
#[derive(Debug)]
pub struct Args {
    /// `--seconds S`: how long the example runs (> 0).
    pub seconds: f64,
    /// `--out PATH`, where the example accepts it.
    pub out: Option<String>,
}

/// Parses `std::env::args()`: `None` after printing `usage` for `--help`. `--out` is refused
/// unless `accepts_out`.
pub fn parse(usage: &str, default_seconds: f64, accepts_out: bool) -> Result<Option<Args>, String> {
    let mut a = Args {
        seconds: default_seconds,
        out: None,
    };
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        match flag.as_str() {
            "--seconds" => {
                a.seconds = args
                    .next()
                    .and_then(|s| s.parse::<f64>().ok())
                    .filter(|s| s.is_finite() && *s > 0.0)
                    .ok_or("--seconds needs a number > 0")?;
            }
            "--out" if accepts_out => a.out = Some(args.next().ok_or("--out needs a path")?),
            "-h" | "--help" => {
                println!("usage: {usage}");
                return Ok(None);
            }
            other => return Err(format!("unknown argument {other:?} (try --help)")),
        }
    }
    Ok(Some(a))
}
