//! The command-line reference in `docs/reference/`, generated from the clap definitions
//! that `ember` parses with: `cli.md` (Markdown, every command and flag under the
//! headings of `--help`) and a man page per command in `man/` (clap_mangen). The test
//! regenerates them and fails when the checked-in copy differs;
//! `EMBER_UPDATE_REFERENCE=1 cargo test --release --bin ember reference` rewrites it.

use std::fmt::Write;
use std::path::{Path, PathBuf};

use clap::{Arg, ArgAction, Command, CommandFactory};

/// The command that rewrites the reference.
const UPDATE: &str = "EMBER_UPDATE_REFERENCE=1 cargo test --release --bin ember reference";

fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/reference")
}

/// Every file of the reference: (path under docs/reference, contents).
fn generate() -> Vec<(PathBuf, String)> {
    let mut root = crate::Cli::command();
    root.build();
    let mut files = vec![(PathBuf::from("cli.md"), markdown(&root))];
    let mut commands = vec![(root.clone(), "ember".to_owned())];
    for sub in root.get_subcommands().filter(|s| s.get_name() != "help") {
        commands.push((sub.clone(), format!("ember-{}", sub.get_name())));
    }
    for (command, name) in commands {
        // clap names commands with `&'static str` (without its `string` feature).
        let static_name: &'static str = Box::leak(name.clone().into_boxed_str());
        let man = clap_mangen::Man::new(command.name(static_name)).manual("ember manual");
        let mut page = Vec::new();
        man.render(&mut page).expect("rendering to memory");
        let page = String::from_utf8(page).expect("man pages are UTF-8");
        files.push((PathBuf::from("man").join(format!("{name}.1")), page));
    }
    files
}

/// The Markdown reference: the top-level command, then each subcommand.
fn markdown(root: &Command) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Command-line reference\n\n<!-- Generated from ember's clap definitions by \
         src/cli/reference.rs: do not edit. To update: {UPDATE} -->\n\n\
         Every command and flag of `ember {}`, as `ember COMMAND --help` prints them. \
         The [guide](../guide.md) explains them by task; `man/` holds the same as man \
         pages (`man -l docs/reference/man/ember-render.1`).\n",
        root.get_version().unwrap_or_default()
    );
    let subcommands: Vec<&Command> = root
        .get_subcommands()
        .filter(|c| c.get_name() != "help")
        .collect();
    for sub in &subcommands {
        let about = sub.get_about().map(|a| a.to_string()).unwrap_or_default();
        let _ = writeln!(s, "- [`ember {0}`](#ember-{0}): {about}", sub.get_name());
    }
    let _ = writeln!(s);
    command_section(&mut s, root, "ember");
    for sub in subcommands {
        command_section(&mut s, sub, &format!("ember {}", sub.get_name()));
    }
    s
}

fn command_section(s: &mut String, command: &Command, name: &str) {
    let _ = writeln!(s, "## `{name}`\n");
    if let Some(about) = command.get_long_about().or(command.get_about()) {
        let _ = writeln!(s, "{about}\n");
    }
    let usage = command.clone().bin_name(name).render_usage().to_string();
    let usage = usage.trim_start_matches("Usage: ");
    let _ = writeln!(s, "```\n{usage}\n```\n");
    let mut headings: Vec<Option<&str>> = Vec::new();
    for arg in visible(command) {
        let heading = heading_of(arg);
        if !headings.contains(&heading) {
            headings.push(heading);
        }
    }
    for heading in headings {
        let title = heading.unwrap_or(if command.get_name() == "ember" {
            "Options"
        } else {
            "Arguments and options"
        });
        let _ = writeln!(s, "### {title}\n");
        for arg in visible(command).filter(|a| heading_of(a) == heading) {
            argument(s, arg);
        }
    }
    if let Some(after) = command.get_after_long_help() {
        let _ = writeln!(s, "```text\n{after}\n```\n");
    }
}

/// The arguments `--help` shows (clap's own `--help` and `--version` included).
fn visible(command: &Command) -> impl Iterator<Item = &Arg> {
    command.get_arguments().filter(|a| !a.is_hide_set())
}

/// The heading an argument is listed under; positional arguments come first.
fn heading_of(arg: &Arg) -> Option<&str> {
    match arg.is_positional() {
        true => None,
        false => arg.get_help_heading().filter(|h| *h != "Options"),
    }
}

fn argument(s: &mut String, arg: &Arg) {
    let names = match (arg.get_short(), arg.get_long()) {
        _ if arg.is_positional() => format!("<{}>", arg.get_id().as_str().to_uppercase()),
        (Some(short), Some(long)) => format!("-{short}, --{long}"),
        (None, Some(long)) => format!("--{long}"),
        (Some(short), None) => format!("-{short}"),
        (None, None) => arg.get_id().to_string(),
    };
    let takes_value = matches!(arg.get_action(), ArgAction::Set | ArgAction::Append);
    let value = match (takes_value && !arg.is_positional(), arg.get_value_names()) {
        (true, Some(names)) => format!(" <{}>", names.join("> <")),
        (true, None) => format!(" <{}>", arg.get_id().as_str().to_uppercase()),
        (false, _) => String::new(),
    };
    let _ = writeln!(s, "- **`{names}{value}`**");
    let help = arg
        .get_long_help()
        .or(arg.get_help())
        .map(|h| h.to_string());
    for paragraph in help.unwrap_or_default().split("\n\n") {
        let _ = writeln!(s, "\n  {}", paragraph.replace('\n', "\n  "));
    }
    let defaults: Vec<String> = arg
        .get_default_values()
        .iter()
        .map(|d| d.to_string_lossy().into_owned())
        .collect();
    if !defaults.is_empty() && takes_value {
        let _ = writeln!(s, "\n  Default: `{}`", defaults.join(","));
    }
    let values: Vec<String> = arg
        .get_possible_values()
        .iter()
        .filter(|v| !v.is_hide_set())
        .map(|v| match v.get_help() {
            Some(help) => format!("`{}`: {help}", v.get_name()),
            None => format!("`{}`", v.get_name()),
        })
        .collect();
    if !values.is_empty() && takes_value {
        let _ = writeln!(s, "\n  Values: {}", values.join("; "));
    }
    let _ = writeln!(s);
}

#[test]
fn reference_is_current() {
    let dir = reference_dir();
    let update = std::env::var_os("EMBER_UPDATE_REFERENCE").is_some_and(|v| v == "1");
    let mut stale = Vec::new();
    for (path, text) in generate() {
        let path = dir.join(path);
        if update {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &text).unwrap();
        } else if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
            stale.push(path.display().to_string());
        }
    }
    assert!(
        stale.is_empty(),
        "the command-line reference is out of date with the flags ({}): run `{UPDATE}`",
        stale.join(", ")
    );
}
