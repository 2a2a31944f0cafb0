use repose::calibrate::surrogate::*;
use repose::calibrate::table::Table;
use std::path::Path;

#[test]
fn explore() {
    let path = Path::new("experiments/he2019-table-a1/table_a1.csv");
    let t = Table::read(path).unwrap();
    let names = ["e_pp", "mu_pp", "e_pw", "mu_pw"];
    let cols: Vec<Vec<f64>> = names.iter().map(|n| t.numbers(path, n).unwrap()).collect();
    let y = t.numbers(path, "aor").unwrap();
    let n = y.len();
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| cols.iter().map(|c| c[i]).collect())
        .collect();
    let train: Vec<usize> = (0..80).collect();
    let inputs = names
        .iter()
        .zip(&cols)
        .map(|(nm, c)| {
            let tr: Vec<f64> = train.iter().map(|&i| c[i]).collect();
            Scale {
                name: nm.to_string(),
                min: tr.iter().cloned().fold(f64::INFINITY, f64::min),
                max: tr.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            }
        })
        .collect();
    let data = Dataset {
        inputs,
        target: "aor".into(),
        rows,
        targets: y,
        train,
        validation: (80..120).collect(),
    };
    let wd: f64 = std::env::var("WD")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.0);
    let epochs: usize = std::env::var("EPOCHS")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(200);
    for seed in 0..6u64 {
        let mut s = TrainSettings::with_seed(seed);
        s.weight_decay = wd;
        s.lm.epochs = epochs;
        let t0 = std::time::Instant::now();
        let sw = sweep(&data, &s).unwrap();
        let line: Vec<String> = sw
            .rows
            .iter()
            .map(|r| format!("{}:{:.3}/{:.3}", r.hidden, r.train_r2, r.validation_r2))
            .collect();
        eprintln!(
            "seed {seed} wd {wd} ep {epochs} best h={} R2v={:.4} ({:.2}s)\n   {}",
            sw.rows[sw.best].hidden,
            sw.rows[sw.best].validation_r2,
            t0.elapsed().as_secs_f64(),
            line.join(" ")
        );
    }
}
