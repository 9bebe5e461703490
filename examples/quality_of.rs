//! Prints the quality report of an MSH file, τ measured against a reference triangulation
//! when one is given (else the mesh's own edge lengths), or a size expression.
//!
//! `cargo run --release --example quality_of -- MESH.msh [REFERENCE.msh | "h=EXPR"] [--json]`

use blossomquad::msh;
use blossomquad::quality::{self, ReferenceSize, SizeExpr, SizeField};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: quality_of MESH.msh [REFERENCE.msh | h=EXPR] [--json]");
        std::process::exit(2);
    };
    let run = || -> Result<(), Box<dyn std::error::Error>> {
        let mesh = msh::read_file(Path::new(path))?;
        let size = match args.get(1).filter(|a| !a.starts_with("--")) {
            Some(a) if a.starts_with("h=") => SizeField::Expression(SizeExpr::new(&a[2..])?),
            Some(r) => {
                let reference = msh::read_file(Path::new(r))?;
                ReferenceSize::from_mesh(&reference)
                    .map_or(SizeField::SelfEstimate, SizeField::Reference)
            }
            None => SizeField::SelfEstimate,
        };
        let report = quality::report(&mesh, &size)?;
        if args.iter().any(|a| a == "--json") {
            println!("{}", report.to_json());
        } else {
            print!("{report}");
        }
        Ok(())
    };
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
