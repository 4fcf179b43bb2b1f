//! `summary.json` without `null`: serde_json writes a non-finite number as `null`, and a result
//! holds no `inf`, `NaN` or `null` (README "Reliability"). A run that failed may hold non-finite
//! quantities in its last state; they are left out and named instead.

use serde_json::Value;

/// Remove every `null` from `v` (an object's key, an array's element) and return their paths
/// (`flow.boundaries[0].pressure`), in document order. A summary has no other use for `null`:
/// an absent quantity is an absent key.
pub fn drop_nulls(v: &mut Value) -> Vec<String> {
    let mut removed = Vec::new();
    walk(v, String::new(), &mut removed);
    removed
}

fn walk(v: &mut Value, path: String, removed: &mut Vec<String>) {
    match v {
        Value::Object(map) => {
            let nulls: Vec<String> = map
                .iter()
                .filter(|(_, x)| x.is_null())
                .map(|(k, _)| k.clone())
                .collect();
            for k in nulls {
                map.remove(&k);
                removed.push(join(&path, &k));
            }
            for (k, x) in map.iter_mut() {
                let p = join(&path, k);
                walk(x, p, removed);
            }
        }
        Value::Array(items) => {
            // Paths name the indices as written by the run, before any removal.
            for (i, x) in items.iter_mut().enumerate() {
                if x.is_null() {
                    removed.push(format!("{path}[{i}]"));
                } else {
                    walk(x, format!("{path}[{i}]"), removed);
                }
            }
            items.retain(|x| !x.is_null());
        }
        _ => {}
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// [`drop_nulls`], then, where any was removed, the list of them under `non_finite` (a
/// quantity of the last state that was infinite or not a number).
pub fn finite_summary(v: &mut Value) {
    let removed = drop_nulls(v);
    if !removed.is_empty()
        && let Value::Object(map) = v
    {
        map.insert("non_finite".into(), Value::from(removed));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn nulls_are_removed_and_named() {
        let mut v = json!({
            "a": f64::NAN,
            "b": {"c": f64::INFINITY, "d": 1.0},
            "e": [1.0, f64::NEG_INFINITY, {"f": f64::NAN}],
        });
        finite_summary(&mut v);
        assert_eq!(
            v,
            json!({
                "b": {"d": 1.0},
                "e": [1.0, {}],
                "non_finite": ["a", "b.c", "e[1]", "e[2].f"],
            })
        );
        let mut ok = json!({"x": [1, 2], "y": "z"});
        finite_summary(&mut ok);
        assert_eq!(ok, json!({"x": [1, 2], "y": "z"}));
    }
}
