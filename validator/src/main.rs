//! The `ommcheck` command line.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use ommcheck::summary::CatalogSummary;
use ommcheck::vuids::Vuid;

/// A checker for Vulkan opacity-micromap API usage.
#[derive(Parser)]
#[command(name = "ommcheck", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Format {
    Text,
    Json,
}

#[derive(Subcommand)]
enum Command {
    /// Check scene files and print a VUID report.
    Check {
        /// Check the built-in example.
        #[arg(long)]
        example: bool,
        /// Scene files to check.
        scenes: Vec<std::path::PathBuf>,
    },
    /// Map barycentrics to a micro-triangle index, or an index to its micro-triangle.
    Index {
        /// Subdivision level, 0 to 12.
        #[arg(long)]
        level: u32,
        /// Hit barycentrics: u weighs vertex 1, v vertex 2.
        #[arg(long, num_args = 2, value_names = ["U", "V"], allow_negative_numbers = true, conflicts_with = "index")]
        uv: Option<Vec<f32>>,
        /// A micro-triangle index.
        #[arg(long, required_unless_present = "uv")]
        index: Option<u32>,
        /// The error the barycentrics may carry (default: 4 f32 ulps of 1).
        #[arg(long, default_value_t = ommcheck::sim::index::DEFAULT_DELTA)]
        delta: f64,
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
    /// Print a VUID's catalog entry: parent, extensions, statement and link.
    Vuid {
        /// e.g. VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516
        id: String,
    },
}

fn main() -> ExitCode {
    match Cli::parse().command {
        Command::Check { example, scenes } => {
            if !scenes.is_empty() {
                eprintln!("ommcheck: scene files are not supported yet (the scene format arrives with the snapshot reports)");
                return ExitCode::from(2);
            }
            if example {
                // Until the checker core lands, the built-in example is the
                // catalog the checks will cite.
                print!("{}", CatalogSummary::new().render());
                ExitCode::SUCCESS
            } else {
                eprintln!("ommcheck: give scene files or --example");
                ExitCode::from(2)
            }
        }
        Command::Index {
            level,
            uv,
            index,
            delta,
            format,
        } => index_command(level, uv.as_deref(), index, delta, format),
        Command::Vuid { id } => match Vuid::from_id(&id) {
            Some(v) => {
                let info = v.info();
                println!("{}", info.id);
                println!(
                    "  parent:     {} ({:?}, {:?})",
                    info.parent, info.parent_kind, info.kind
                );
                println!(
                    "  extensions: {}",
                    info.extensions
                        .extension_names()
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                if let Some(k) = info.khronos_layer_checks {
                    println!(
                        "  checked by the Khronos validation layer: {}",
                        if k { "yes" } else { "no" }
                    );
                }
                println!("  statement:  {}", info.text);
                println!("  link:       {}", info.link());
                ExitCode::SUCCESS
            }
            None => {
                eprintln!(
                    "ommcheck: {id} is not a micromap VUID of Vulkan {}",
                    ommcheck::vuids::REGISTRY_VERSION
                );
                ExitCode::from(1)
            }
        },
    }
}

/// `ommcheck index`: one mapping, as text or JSON.
fn index_command(
    level: u32,
    uv: Option<&[f32]>,
    index: Option<u32>,
    delta: f64,
    format: Format,
) -> ExitCode {
    use ommcheck::sim::index::{candidates, spec_triangle, MicroTriangle, MAX_LEVEL};
    if level > MAX_LEVEL {
        eprintln!("ommcheck: --level {level} is above the highest subdivision level, {MAX_LEVEL}");
        return ExitCode::from(2);
    }
    let (triangle, ambiguous) = match (uv, index) {
        (Some([u, v]), _) => {
            let (triangle, set) = match (
                spec_triangle(*u, *v, level),
                candidates(*u, *v, level, delta),
            ) {
                (Ok(t), Ok(set)) => (t, set),
                (_, Err(ommcheck::sim::index::BaryError::TooUncertain)) => {
                    eprintln!("ommcheck: --delta {delta} spans more than {} micro-triangles: the whole triangle is uncertain", ommcheck::sim::index::MAX_CANDIDATE_SPAN);
                    return ExitCode::from(2);
                }
                _ => {
                    eprintln!("ommcheck: the barycentrics ({u}, {v}) are not numbers");
                    return ExitCode::from(2);
                }
            };
            let ambiguous: Vec<u32> = if set.len() > 1 {
                set.into_iter().collect()
            } else {
                Vec::new()
            };
            (triangle, Some(ambiguous))
        }
        (_, Some(i)) => match MicroTriangle::from_index(i, level) {
            Some(t) => (t, None),
            None => {
                eprintln!("ommcheck: index {i} is not below 4^{level}");
                return ExitCode::from(2);
            }
        },
        _ => unreachable!("clap requires --uv or --index"),
    };
    let index = triangle.index(level);
    let vertices = triangle.vertices(level);
    match format {
        Format::Json => {
            let mut json = serde_json::json!({
                "index": index,
                "upright": triangle.upright,
                "i": triangle.i,
                "j": triangle.j,
                "vertices": vertices.map(|(u, v)| [u, v]),
            });
            if let Some(ambiguous) = ambiguous {
                json["ambiguous"] = serde_json::json!(ambiguous);
            }
            println!("{json}");
        }
        Format::Text => {
            let shape = if triangle.upright {
                "upright"
            } else {
                "inverted"
            };
            println!(
                "index {index} at level {level}: {shape} micro-triangle, cell (i, j) = ({}, {})",
                triangle.i, triangle.j
            );
            let corners: Vec<String> = vertices
                .iter()
                .map(|(u, v)| format!("({u}, {v})"))
                .collect();
            println!("vertices (u, v): {}", corners.join(", "));
            match ambiguous.as_deref() {
                Some([]) => println!("definite within delta {delta}"),
                Some(set) => println!("ambiguous within delta {delta}: any of {set:?}"),
                None => {}
            }
        }
    }
    ExitCode::SUCCESS
}
