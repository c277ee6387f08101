//! Maximum relative error of the tabulated six-parameter path per table size and zenith
//! limit, for the Table 1 materials and random parameter sets in the paper's range:
//! `cargo run --release -p brdf-tests --example table_domain`.

use brdf_core::table::TABLE_SIZES;
use brdf_tests::table_error::table_error;
use brdf_tests::{dense_grid_f32, random_six, SplitMix, TABLE1};

fn main() {
    let grid = dense_grid_f32();
    let mut rng = SplitMix(0x7ab1e);
    let random: Vec<[f64; 6]> = (0..40).map(|_| random_six(&mut rng)).collect();
    println!("max relative error of the table lookup against exact f64 (RMS in brackets)");
    for limit in [60.0, 80.0, 85.0, 89.0, 89.9] {
        for nodes in TABLE_SIZES {
            let mut line = format!("zenith <= {limit:4} deg, {nodes:4} nodes:");
            for (name, p) in TABLE1 {
                let (m, r, _, _) = table_error(p, nodes, limit, &grid);
                line += &format!(" {name} {m:.1e} ({r:.0e})");
            }
            let worst = random
                .iter()
                .map(|&p| table_error(p, nodes, limit, &grid))
                .fold((0.0, [0.0; 3]), |w, e| if e.0 > w.0 { (e.0, e.2) } else { w });
            line += &format!(" | 40 random sets {:.1e} at {:?}", worst.0, worst.1);
            println!("{line}");
        }
    }
}
