//! What the evaluations say: the Pareto front of error against render time, and the
//! sensitivity of the objective to each parameter — the bias-corrected correlation ratio
//! ε² over quantile bins ("fANOVA-lite": the share of the variance of ln(objective)
//! explained by that parameter alone, which sees U-shaped effects), with Spearman's ρ for
//! the direction.

/// Indices of the non-dominated points (minimising both coordinates), ordered by the first
/// coordinate ascending; ties go to the lower index, non-finite points are dropped.
pub(crate) fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
            .then(a.cmp(&b))
    });
    let mut best = f64::INFINITY;
    let mut front = Vec::new();
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// ε² = max(0, (SS_between − (B−1)·MS_within) / SS_tot) of `y` grouped by `x`: by value
/// when `categorical`, else into `bins` quantile bins. `None` with fewer than 4 points or
/// no variance.
pub(crate) fn epsilon_squared(x: &[f64], y: &[f64], bins: usize, categorical: bool) -> Option<f64> {
    let n = x.len();
    if n < 4 || y.len() != n {
        return None;
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]).then(a.cmp(&b)));
    let mut group = vec![0usize; n];
    let mut groups = 0;
    for (rank, &i) in order.iter().enumerate() {
        group[i] = if categorical {
            // Consecutive equal values share a group.
            if rank > 0 && x[i] != x[order[rank - 1]] {
                groups += 1;
            }
            groups
        } else {
            rank * bins.max(1) / n
        };
    }
    let k = group.iter().max().map_or(0, |g| g + 1);
    let mean = y.iter().sum::<f64>() / n as f64;
    let (mut sum, mut count) = (vec![0.0; k], vec![0usize; k]);
    for i in 0..n {
        sum[group[i]] += y[i];
        count[group[i]] += 1;
    }
    let ss_tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let used: Vec<usize> = (0..k).filter(|&g| count[g] > 0).collect();
    if ss_tot <= 0.0 || used.len() < 2 || used.len() >= n {
        return None;
    }
    let ss_between: f64 = used
        .iter()
        .map(|&g| count[g] as f64 * (sum[g] / count[g] as f64 - mean).powi(2))
        .sum();
    let ms_within = (ss_tot - ss_between) / (n - used.len()) as f64;
    Some(((ss_between - (used.len() as f64 - 1.0) * ms_within) / ss_tot).max(0.0))
}

/// Quantile bins for `n` points: about 8 points a bin, 3 to 10 bins.
pub(crate) fn bins_for(n: usize) -> usize {
    (n / 8).clamp(3, 10)
}

/// Spearman's rank correlation (average ranks for ties); `None` without variance.
pub(crate) fn spearman(x: &[f64], y: &[f64]) -> Option<f64> {
    if x.len() < 3 || x.len() != y.len() {
        return None;
    }
    let (rx, ry) = (ranks(x), ranks(y));
    let n = x.len() as f64;
    let (mx, my) = (rx.iter().sum::<f64>() / n, ry.iter().sum::<f64>() / n);
    let c: f64 = rx.iter().zip(&ry).map(|(a, b)| (a - mx) * (b - my)).sum();
    let vx: f64 = rx.iter().map(|a| (a - mx).powi(2)).sum();
    let vy: f64 = ry.iter().map(|b| (b - my).powi(2)).sum();
    (vx > 0.0 && vy > 0.0).then(|| c / (vx * vy).sqrt())
}

fn ranks(v: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i + 1;
        while j < order.len() && v[order[j]] == v[order[i]] {
            j += 1;
        }
        for &k in &order[i..j] {
            r[k] = (i + j + 1) as f64 / 2.0;
        }
        i = j;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_only_non_dominated_points() {
        let pts = [
            (1.0, 5.0),
            (2.0, 3.0),
            (2.5, 4.0),
            (3.0, 1.0),
            (f64::INFINITY, 0.1),
            (2.0, 3.0),
        ];
        assert_eq!(pareto_front(&pts), vec![0, 1, 3]);
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn epsilon_squared_sees_a_u_shape_that_spearman_misses() {
        let x: Vec<f64> = (0..80).map(|i| f64::from(i) / 79.0).collect();
        let u: Vec<f64> = x.iter().map(|v| (v - 0.5).powi(2)).collect();
        let e = epsilon_squared(&x, &u, bins_for(80), false).unwrap();
        assert!(e > 0.8, "U-shape ε² {e}");
        assert!(spearman(&x, &u).unwrap().abs() < 0.1);
        // Noise unrelated to x: ε² near 0.
        let noise: Vec<f64> = (0..80u64)
            .map(|i| ((i.wrapping_mul(2654435761) % 1000) as f64) / 1000.0)
            .collect();
        let e = epsilon_squared(&x, &noise, bins_for(80), false).unwrap();
        assert!(e < 0.1, "noise ε² {e}");
        // Categories.
        let c = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
        let y = [1.0, 5.0, 1.1, 5.2, 0.9, 4.8];
        assert!(epsilon_squared(&c, &y, 3, true).unwrap() > 0.95);
        assert_eq!(spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]), Some(-1.0));
    }
}
