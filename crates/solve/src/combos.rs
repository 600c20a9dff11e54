//! Turning a numerical null space into readable parameter combinations.

use crate::Combination;

/// Entries smaller than this, relative to the largest entry of their combination (in scaled
/// units), are rounding noise and dropped.
const DROP: f64 = 1e-6;
/// Relative tolerance for "equal" coefficients (sum / difference).
const EQUAL: f64 = 1e-6;

/// Describes a null space as sparse, named parameter combinations.
///
/// `null` holds the null-space directions, each a vector with one entry per parameter, in
/// *scaled* units (parameter change × column norm of the Jacobian, so that entries are
/// comparable whatever the parameters' units); `scale[i]` is parameter `i`'s column norm and
/// `names[i]` its name. The returned [`Combination::params`] index into these rows and
/// [`Combination::coefficients`] are in parameter units (`null[i] / scale[i]`), relative to the
/// first parameter of the combination.
///
/// Method: the basis is brought to reduced row echelon form with complete pivoting (each
/// combination gets a "pivot" parameter that no other combination contains; independent groups
/// of parameters separate), entries below 10⁻⁶ of their combination's largest are dropped, and
/// each combination is described:
/// - one parameter: it is not observed at all;
/// - a group of parameters (connected through shared combinations) of which exactly one linear
///   combination is observed: that combination, in words ("only their sum is observed" when
///   moving two parameters in opposite directions by the same amount changes nothing, "only
///   their difference is observed" when moving them together changes nothing);
/// - otherwise the unobservable direction itself, as ratios relative to the first parameter.
pub fn describe_null_space<S: AsRef<str>>(
    null: &[Vec<f64>],
    scale: &[f64],
    names: &[S],
) -> Vec<Combination> {
    let k = names.len();
    assert_eq!(scale.len(), k, "one scale per parameter");
    assert!(
        null.iter().all(|v| v.len() == k),
        "one entry per parameter in each direction"
    );
    let (rows, pivots) = reduced_echelon(null.to_vec());
    let mut combos: Vec<(Vec<usize>, Vec<f64>, usize)> = Vec::new();
    for (row, &pivot) in rows.iter().zip(&pivots) {
        let max = row.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let params: Vec<usize> = (0..k).filter(|&j| row[j].abs() > DROP * max).collect();
        let scaled: Vec<f64> = params.iter().map(|&j| row[j]).collect();
        combos.push((params, scaled, pivot));
    }
    combos.sort_by(|a, b| a.0.cmp(&b.0));
    let cluster = clusters(k, &combos);
    let names: Vec<&str> = names.iter().map(AsRef::as_ref).collect();
    combos
        .iter()
        .map(|(params, scaled, _)| {
            let phys: Vec<f64> = params
                .iter()
                .zip(scaled)
                .map(|(&j, v)| v / scale[j])
                .collect();
            let coefficients: Vec<f64> = phys.iter().map(|v| v / phys[0]).collect();
            let members: Vec<usize> = (0..k)
                .filter(|&j| cluster[j] == cluster[params[0]])
                .collect();
            let in_cluster: Vec<&(Vec<usize>, Vec<f64>, usize)> = combos
                .iter()
                .filter(|c| cluster[c.0[0]] == cluster[params[0]])
                .collect();
            let why = explain(params, &coefficients, &members, &in_cluster, scale, &names);
            Combination {
                params: params.clone(),
                coefficients,
                why,
            }
        })
        .collect()
}

/// Gauss–Jordan elimination with complete pivoting on the rows (null-space directions).
/// Returns the reduced rows and each row's pivot column.
fn reduced_echelon(mut a: Vec<Vec<f64>>) -> (Vec<Vec<f64>>, Vec<usize>) {
    let d = a.len();
    let k = a.first().map_or(0, Vec::len);
    let scale = a.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut is_pivot = vec![false; k];
    let mut pivots = Vec::with_capacity(d);
    for s in 0..d {
        // Largest entry; among near-ties the lowest column, then the lowest row (deterministic
        // under rounding).
        let mut best = (0.0_f64, s, 0);
        for j in (0..k).filter(|&j| !is_pivot[j]) {
            for (i, row) in a.iter().enumerate().skip(s) {
                if row[j].abs() > best.0 * (1.0 + 1e-9) {
                    best = (row[j].abs(), i, j);
                }
            }
        }
        let (val, i, j) = best;
        if val <= 1e-12 * scale || val == 0.0 {
            a.truncate(s);
            break;
        }
        a.swap(s, i);
        let inv = 1.0 / a[s][j];
        for v in a[s].iter_mut() {
            *v *= inv;
        }
        a[s][j] = 1.0;
        let pivot_row = a[s].clone();
        for (i2, row) in a.iter_mut().enumerate() {
            if i2 == s {
                continue;
            }
            let f = row[j];
            if f != 0.0 {
                for (v, p) in row.iter_mut().zip(&pivot_row) {
                    *v -= f * p;
                }
                row[j] = 0.0;
            }
        }
        is_pivot[j] = true;
        pivots.push(j);
    }
    (a, pivots)
}

/// Connected groups of parameters (through shared combinations): a label per parameter.
fn clusters(k: usize, combos: &[(Vec<usize>, Vec<f64>, usize)]) -> Vec<usize> {
    let mut label: Vec<usize> = (0..k).collect();
    fn find(label: &mut [usize], mut i: usize) -> usize {
        while label[i] != i {
            label[i] = label[label[i]];
            i = label[i];
        }
        i
    }
    for (params, _, _) in combos {
        let root = find(&mut label, params[0]);
        for &p in &params[1..] {
            let r = find(&mut label, p);
            let (lo, hi) = (root.min(r), root.max(r));
            label[hi] = lo;
            let _ = find(&mut label, hi);
        }
    }
    (0..k).map(|i| find(&mut label, i)).collect()
}

fn explain(
    params: &[usize],
    coefficients: &[f64],
    members: &[usize],
    in_cluster: &[&(Vec<usize>, Vec<f64>, usize)],
    scale: &[f64],
    names: &[&str],
) -> String {
    let name = |j: usize| names[j];
    if params.len() == 1 {
        return format!("{} is not observed by these runs", name(params[0]));
    }
    let direction = direction(params, coefficients, names);
    if members.len() != in_cluster.len() + 1 {
        return format!(
            "moving {direction} changes nothing: only combinations unaffected by that are observed"
        );
    }
    // Exactly one combination of the group is observed: the functional g with g·n = 0 for every
    // null direction n. In scaled units the one non-pivot column f gives g_f = 1 and
    // g_pivot(row) = −row_f; in parameter units g_j = scale_j · g_scaled_j.
    let pivots: Vec<usize> = in_cluster.iter().map(|c| c.2).collect();
    let Some(&free) = members.iter().find(|j| !pivots.contains(j)) else {
        return format!("moving {direction} changes nothing");
    };
    let mut g: Vec<f64> = members
        .iter()
        .map(|&j| {
            if j == free {
                return 1.0;
            }
            let row = in_cluster.iter().find(|c| c.2 == j).expect("pivot row");
            let entry = row
                .0
                .iter()
                .position(|&p| p == free)
                .map_or(0.0, |pos| row.1[pos]);
            -entry
        })
        .collect();
    for (gj, &j) in g.iter_mut().zip(members) {
        *gj *= scale[j];
    }
    let g0 = g[0];
    for gj in &mut g {
        *gj /= g0;
    }
    let all_one = g.iter().all(|v| (v - 1.0).abs() <= EQUAL);
    if members.len() == 2 {
        let t = coefficients[1];
        if (t - 1.0).abs() <= EQUAL {
            return format!(
                "only their difference is observed: moving {} and {} together changes nothing",
                name(params[0]),
                name(params[1])
            );
        }
        if (t + 1.0).abs() <= EQUAL {
            return format!(
                "only their sum is observed: raising {} and lowering {} by the same amount changes nothing",
                name(params[0]),
                name(params[1])
            );
        }
        return format!(
            "only the combination {} is observed: moving {direction} changes nothing",
            linear_form(members, &g, names)
        );
    }
    let what = if all_one {
        format!(
            "only their sum {} is observed",
            linear_form(members, &g, names)
        )
    } else {
        format!(
            "only the combination {} is observed",
            linear_form(members, &g, names)
        )
    };
    format!("{what}: moving {direction} changes nothing")
}

/// "a and b in the ratio 1 : -0.5", "a, b and c in the ratio 1 : 2 : -1".
fn direction(params: &[usize], coefficients: &[f64], names: &[&str]) -> String {
    let list: Vec<&str> = params.iter().map(|&j| names[j]).collect();
    let (last, head) = list.split_last().expect("at least two parameters");
    let ratio: Vec<String> = coefficients.iter().map(|&c| number(c)).collect();
    format!(
        "{} and {last} in the ratio {}",
        head.join(", "),
        ratio.join(" : ")
    )
}

/// "a + 2*b - c".
fn linear_form(members: &[usize], g: &[f64], names: &[&str]) -> String {
    let mut s = String::new();
    for (i, (&j, &c)) in members.iter().zip(g).enumerate() {
        let sign = if c < 0.0 { "-" } else { "+" };
        let mag = c.abs();
        let term = if (mag - 1.0).abs() <= EQUAL {
            names[j].to_string()
        } else {
            format!("{}*{}", number(mag), names[j])
        };
        if i == 0 {
            if c < 0.0 {
                s.push('-');
            }
            s.push_str(&term);
        } else {
            s.push_str(&format!(" {sign} {term}"));
        }
    }
    s
}

/// A coefficient with up to six significant digits.
fn number(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        return format!("{x:.4e}");
    }
    let digits = (5 - a.log10().floor().max(-3.0) as i32).clamp(0, 9) as usize;
    let s = format!("{x:.digits$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" { "0".into() } else { s }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(k: usize) -> Vec<String> {
        (0..k).map(|i| format!("p{i}")).collect()
    }

    fn describe(null: &[Vec<f64>], scale: &[f64]) -> Vec<Combination> {
        describe_null_space(null, scale, &names(scale.len()))
    }

    #[test]
    fn single_parameter_is_not_observed() {
        let c = describe(&[vec![0.0, 1.0, 3e-9]], &[1.0; 3]);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].params, vec![1]);
        assert_eq!(c[0].coefficients, vec![1.0]);
        assert_eq!(c[0].why, "p1 is not observed by these runs");
    }

    #[test]
    fn opposite_coefficients_mean_only_the_sum_is_observed() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let c = describe(&[vec![-h, h, 0.0]], &[1.0; 3]);
        assert_eq!(c[0].params, vec![0, 1]);
        assert!((c[0].coefficients[1] + 1.0).abs() < 1e-12);
        assert!(
            c[0].why.starts_with("only their sum is observed"),
            "{}",
            c[0].why
        );
    }

    #[test]
    fn equal_coefficients_mean_only_the_difference_is_observed() {
        let c = describe(&[vec![0.0, 0.6, 0.6]], &[1.0; 3]);
        assert_eq!(c[0].params, vec![1, 2]);
        assert!(
            c[0].why.starts_with("only their difference is observed"),
            "{}",
            c[0].why
        );
    }

    #[test]
    fn coefficients_are_reported_in_parameter_units() {
        // Column b is twice column a, so a + 2b is observed. In scaled units (column norms 1 and
        // 2) the null direction is (1, -1)/√2; in parameter units it is (1, -0.5).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let c = describe(&[vec![h, -h]], &[1.0, 2.0]);
        assert!(
            (c[0].coefficients[1] + 0.5).abs() < 1e-12,
            "{:?}",
            c[0].coefficients
        );
        assert!(
            c[0].why
                .starts_with("only the combination p0 + 2*p1 is observed"),
            "{}",
            c[0].why
        );
    }

    #[test]
    fn two_dimensional_null_space_separates_into_readable_pairs() {
        // span{(1, 1, 0, 0), (0, 0, 1, -1)} mixed by a rotation.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let (c, s) = (0.8, 0.6);
        let a = [h, h, 0.0, 0.0];
        let b = [0.0, 0.0, h, -h];
        let v1: Vec<f64> = (0..4).map(|i| c * a[i] + s * b[i]).collect();
        let v2: Vec<f64> = (0..4).map(|i| -s * a[i] + c * b[i]).collect();
        let combos = describe(&[v1, v2], &[1.0; 4]);
        assert_eq!(combos.len(), 2);
        assert_eq!(combos[0].params, vec![0, 1]);
        assert_eq!(combos[1].params, vec![2, 3]);
        assert!(
            combos[0].why.starts_with("only their difference"),
            "{}",
            combos[0].why
        );
        assert!(
            combos[1].why.starts_with("only their sum"),
            "{}",
            combos[1].why
        );
    }

    #[test]
    fn three_identical_columns_leave_only_their_sum() {
        // Null space of (1, 1, 1): two directions; the group has one observed combination.
        let v1 = vec![1.0 / 2f64.sqrt(), -1.0 / 2f64.sqrt(), 0.0];
        let v2 = vec![1.0 / 6f64.sqrt(), 1.0 / 6f64.sqrt(), -2.0 / 6f64.sqrt()];
        let combos = describe(&[v1, v2], &[1.0; 3]);
        assert_eq!(combos.len(), 2);
        for c in &combos {
            assert!(
                c.why.starts_with("only their sum p0 + p1 + p2 is observed"),
                "{}",
                c.why
            );
        }
    }

    #[test]
    fn general_direction_is_given_as_ratios() {
        // One null direction over three parameters: two combinations are observed.
        let combos = describe(&[vec![2.0, -1.0, 4.0]], &[1.0; 3]);
        assert_eq!(combos[0].coefficients, vec![1.0, -0.5, 2.0]);
        assert_eq!(
            combos[0].why,
            "moving p0, p1 and p2 in the ratio 1 : -0.5 : 2 changes nothing: only combinations \
             unaffected by that are observed"
        );
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(number(1.0), "1");
        assert_eq!(number(-0.5), "-0.5");
        assert_eq!(number(2.0 / 3.0), "0.666667");
        assert_eq!(number(1234.5), "1234.5");
        assert_eq!(number(1e-7), "1.0000e-7");
    }

    #[test]
    fn empty_null_space_has_no_combinations() {
        assert!(describe(&[], &[1.0; 2]).is_empty());
    }
}
