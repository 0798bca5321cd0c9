//! Writes the four pattern files of a small generated pattern into a directory:
//! `cargo run --release -p clothcast-pattern --example demo -- <out-dir>`.

use clothcast_pattern::{MarkKind, PatternOptions, PieceInput, PointMark, SeamSide, all_writers, build_pattern};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| "pattern-demo".into());
    std::fs::create_dir_all(&dir)?;
    let side = |seam: usize, start: usize, end: usize, forward: bool| SeamSide {
        seam,
        label: format!("A{seam}"),
        start,
        end,
        forward,
    };
    // Four panels of a box-like formwork sewn in a ring, plus a concave gusset.
    let mut pieces: Vec<PieceInput> = (0..4)
        .map(|i| PieceInput {
            id: i,
            name: format!("P{i}"),
            outline: vec![[0.0, 0.0], [420.0, 20.0], [400.0, 610.0], [210.0, 680.0], [10.0, 600.0]],
            seams: vec![side(i, 1, 2, true), side((i + 3) % 4, 4, 0, false)],
            marks: vec![PointMark { kind: MarkKind::Suspension, position: [210.0, 620.0], label: format!("S{i}") }],
        })
        .collect();
    pieces.push(PieceInput {
        id: 9,
        name: "G".into(),
        outline: vec![
            [0.0, 0.0],
            [500.0, 0.0],
            [500.0, 300.0],
            [300.0, 300.0],
            [300.0, 120.0],
            [200.0, 120.0],
            [200.0, 300.0],
            [0.0, 300.0],
        ],
        seams: vec![side(20, 2, 3, true), side(20, 7, 0, true)],
        marks: vec![
            PointMark { kind: MarkKind::Pour, position: [100.0, 200.0], label: "pour".into() },
            PointMark { kind: MarkKind::Clamp, position: [400.0, 200.0], label: "C1".into() },
        ],
    });
    let pattern = build_pattern(&pieces, &PatternOptions { fabric_width_mm: 1000.0, ..Default::default() })?;
    for w in all_writers() {
        let path = std::path::Path::new(&dir).join(w.file_name());
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path)?);
        w.write(&pattern, &mut f)?;
        println!("{}", path.display());
    }
    println!(
        "{} pieces, roll {} x {:.0} mm, utilisation {:.3}, notches {}",
        pattern.stats.pieces,
        pattern.fabric_width_mm,
        pattern.fabric_length_mm,
        pattern.utilisation,
        pattern.stats.notches
    );
    Ok(())
}
