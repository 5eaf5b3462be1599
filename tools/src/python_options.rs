//! Python's option tables (`BUILD_OPTIONS`, `MESH_OPTIONS` in python/pomc/__init__.py) against
//! the command line's: the same names and the same defaults. The command line's defaults are
//! checked against the library's `Default` by each command's tests, so the three agree.

use clap::CommandFactory;

/// `"key": value,` lines of the dict `name` in the Python package.
fn python_table(name: &str) -> Vec<(String, String)> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../python/pomc/__init__.py");
    let text = std::fs::read_to_string(path).unwrap();
    let start =
        text.find(&format!("\n{name}: Dict[str, Any] = {{")).unwrap_or_else(|| panic!("{name} not found"));
    let body = &text[start..];
    let body = &body[body.find('{').unwrap() + 1..body.find("\n}").unwrap()];
    body.lines()
        .filter_map(|l| {
            let (k, v) = l.trim().trim_end_matches(',').split_once(':')?;
            Some((k.trim().trim_matches('"').to_string(), v.trim().trim_matches('"').to_string()))
        })
        .collect()
}

/// The same value written by Python and by clap: numbers compared as numbers.
fn same(python: &str, clap: Option<&str>) -> bool {
    match (python, clap) {
        ("None", None) => true,
        ("True", Some("true")) | ("False", Some("false") | None) => true,
        (p, Some(c)) => match (p.parse::<f64>(), c.parse::<f64>()) {
            (Ok(a), Ok(b)) => a == b,
            _ => p == c,
        },
        _ => false,
    }
}

/// Each Python option is a flag of `command` with the same default (`flag` for Python's negation
/// `no_flag`'s opposite: `simplify` ↔ `--no-simplify`), apart from `python_only`; each of the
/// command's options is in Python apart from `cli_only`.
fn check(command: &str, table: &str, python_only: &[&str], cli_only: &[&str]) {
    let cli = crate::Cli::command();
    let cmd = cli.find_subcommand(command).unwrap();
    let default = |long: &str| -> Option<Option<String>> {
        let a = cmd.get_arguments().find(|a| a.get_long() == Some(long))?;
        Some(a.get_default_values().first().map(|v| v.to_string_lossy().into_owned()))
    };
    let python = python_table(table);
    assert!(python.len() > 5, "{table}: {python:?}");
    for (key, value) in &python {
        let long = key.replace('_', "-");
        if python_only.contains(&key.as_str()) {
            continue;
        }
        match (default(&long), default(&format!("no-{long}"))) {
            (Some(d), _) => {
                assert!(
                    same(value, d.as_deref()),
                    "{table}[{key}] = {value}, `pomc {command} --{long}` default {d:?}"
                )
            }
            (None, Some(d)) => {
                let negated = if value == "True" { "False" } else { "True" };
                assert!(same(negated, d.as_deref()), "{table}[{key}] = {value}, `--no-{long}` default {d:?}");
            }
            (None, None) => panic!("{table}[{key}]: `pomc {command}` has no --{long}"),
        }
    }
    for a in cmd.get_arguments() {
        let Some(long) = a.get_long() else { continue };
        let key = long.replace('-', "_");
        let plain = key.strip_prefix("no_").unwrap_or(&key);
        let known = python.iter().any(|(k, _)| k == &key || k == plain);
        assert!(
            known || cli_only.contains(&long),
            "`pomc {command} --{long}` has no Python option in {table}"
        );
    }
}

#[test]
fn python_build_options_are_the_command_lines() {
    check(
        "build",
        "BUILD_OPTIONS",
        &[],
        &[
            "colour",
            "depth",
            "output",
            "json",
            "quiet",
            "help",
            "freedom-radius",
            "convention",
            "center",
            "report",
        ],
    );
}

#[test]
fn python_mesh_options_are_the_command_lines() {
    check(
        "mesh",
        "MESH_OPTIONS",
        &[],
        &["layer", "output", "json", "quiet", "help", "local", "no-metric", "store"],
    );
}

#[test]
fn a_different_default_is_caught() {
    assert!(same("0.08", Some("0.08")) && same("35.0", Some("35")) && same("None", None));
    assert!(!same("0.08", Some("0.1")) && !same("auto", Some("on")) && !same("None", Some("1")));
}
