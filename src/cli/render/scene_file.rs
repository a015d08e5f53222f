//! `ember render SCENE.toml`: a scene file's settings, cameras and environment read as
//! the flags of the same names. The file's flags come first and the command line's
//! after them, and a later flag overrides an earlier one, so the command line wins.
//! Each key is checked alone with the flag's own parser, so a bad value is reported at
//! its line and column.

use std::ffi::OsString;

use anyhow::{bail, Result};
use clap::{ArgMatches, Args, Command, FromArgMatches};

use super::args::RenderArgs;
use ember::scene::{SceneFile, SceneFileError, Setting};

/// Keys of a `[camera.NAME]` table.
const CAMERA_KEYS: [&str; 6] = ["eye", "look-at", "up", "fov", "aperture", "focus-distance"];
/// Keys of `[environment]`; `env` is a path, relative to the scene file.
const ENVIRONMENT_KEYS: [&str; 4] = ["background", "env", "env-scale", "env-rotate"];
/// Flags about one run rather than the scene: the command line's only.
const RUN_ONLY: [&str; 9] = [
    "output",
    "display",
    "json",
    "checkpoint",
    "resume",
    "shard",
    "help",
    "quiet",
    "verbose",
];

/// `ember render`'s flags, and the global `-q` and `-v` (already read by `main`).
fn render_command() -> Command {
    let global = |id: &'static str, short: char| {
        clap::Arg::new(id)
            .short(short)
            .long(id)
            .action(clap::ArgAction::SetTrue)
    };
    RenderArgs::augment_args(Command::new("render"))
        .arg(global("quiet", 'q'))
        .arg(global("verbose", 'v'))
        .args_override_self(true)
}

/// The render's arguments of a command line without a scene file (`user`, the
/// arguments after `render`).
pub fn command_line_args(user: &[OsString]) -> Result<RenderArgs> {
    let argv = std::iter::once(OsString::from("render")).chain(user.iter().cloned());
    let matches = render_command().try_get_matches_from(argv)?;
    Ok(RenderArgs::from_arg_matches(&matches)?)
}

/// The render's arguments: the scene file's flags, then `user` (the command line's
/// arguments after `render`, the scene file among them).
pub fn render_args(file: &SceneFile, user: &[OsString]) -> Result<RenderArgs> {
    let command = render_command();
    let given = command.clone().try_get_matches_from(
        std::iter::once(OsString::from("render")).chain(user.iter().cloned()),
    )?;
    let mut flags: Vec<String> = Vec::new();
    let add = |setting: &Setting, section: &str, flags: &mut Vec<String>| -> Result<()> {
        let args = flag_args(file, setting, section)?;
        check_alone(file, setting, section, &args)?;
        flags.extend(args);
        Ok(())
    };
    for setting in &file.render {
        let key = setting.key.as_str();
        let misplaced = CAMERA_KEYS.contains(&key) || ENVIRONMENT_KEYS.contains(&key);
        let known = command.get_arguments().any(|a| a.get_long() == Some(key));
        if misplaced || RUN_ONLY.contains(&key) || !known || key == "scene" {
            let message = if misplaced {
                format!("`{key}` belongs in a [camera.NAME] table or in [environment]")
            } else if RUN_ONLY.contains(&key) {
                format!("`{key}` is about one run: give --{key} on the command line")
            } else {
                format!("unknown setting `{key}` (the keys of [render] are ember render's flags)")
            };
            return Err(file
                .error(setting.span.clone(), &format!("render.{key}"), &message)
                .into());
        }
        add(setting, "render", &mut flags)?;
    }
    // A sky on the command line replaces the file's whole environment.
    if !(user_gave(&given, "env") || user_gave(&given, "background")) {
        for setting in &file.environment {
            only_keys(file, setting, "environment", &ENVIRONMENT_KEYS)?;
            add(setting, "environment", &mut flags)?;
        }
    }
    if let Some(name) = chosen_camera(file, &given, &file.render)? {
        for setting in &file.cameras[&name] {
            only_keys(file, setting, &format!("camera.{name}"), &CAMERA_KEYS)?;
            add(setting, &format!("camera.{name}"), &mut flags)?;
        }
    }
    let argv = std::iter::once(OsString::from("render"))
        .chain(flags.into_iter().map(OsString::from))
        .chain(user.iter().cloned());
    let matches = command.try_get_matches_from(argv)?;
    Ok(RenderArgs::from_arg_matches(&matches)?)
}

fn user_gave(matches: &ArgMatches, id: &str) -> bool {
    matches.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
}

fn only_keys(file: &SceneFile, setting: &Setting, table: &str, keys: &[&str]) -> Result<()> {
    if keys.contains(&setting.key.as_str()) {
        return Ok(());
    }
    let message = format!(
        "unknown key `{}` (the keys of [{table}] are {})",
        setting.key,
        keys.join(", ")
    );
    Err(file
        .error(
            setting.span.clone(),
            &format!("{table}.{}", setting.key),
            &message,
        )
        .into())
}

/// `--camera NAME`, else `[render] camera = "NAME"`, else the file's only camera.
fn chosen_camera(
    file: &SceneFile,
    given: &ArgMatches,
    render: &[Setting],
) -> Result<Option<String>> {
    let names: Vec<&str> = file.cameras.keys().map(String::as_str).collect();
    let from_file = render.iter().find(|s| s.key == "camera");
    let name = match (given.get_one::<String>("camera"), from_file) {
        (Some(name), _) => name.clone(),
        (None, Some(setting)) => match &setting.value {
            toml::Value::String(name) => name.clone(),
            _ => {
                return Err(file
                    .error(
                        setting.span.clone(),
                        "render.camera",
                        "the name of a [camera.NAME] table",
                    )
                    .into())
            }
        },
        (None, None) if names.len() <= 1 => return Ok(names.first().map(|n| n.to_string())),
        (None, None) => bail!(
            "{} has cameras {}: choose one with --camera NAME or [render] camera = \"NAME\"",
            file.path.display(),
            names.join(", ")
        ),
    };
    if !file.cameras.contains_key(&name) {
        let what = if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        };
        bail!(
            "{} has no camera {name:?} (its cameras: {what})",
            file.path.display()
        );
    }
    Ok(Some(name))
}

/// The command-line arguments of one setting: `--key=value`, `--key` for `true`,
/// nothing for `false`, lists comma-separated; `env` resolved against the file.
fn flag_args(
    file: &SceneFile,
    setting: &Setting,
    section: &str,
) -> Result<Vec<String>, SceneFileError> {
    let key = &setting.key;
    let scalar = |v: &toml::Value| match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) => Some(f.to_string()),
        _ => None,
    };
    let bad = |what: &str| file.error(setting.span.clone(), &format!("{section}.{key}"), what);
    if key == "camera" && section == "render" {
        // Chosen above; not a flag to repeat.
        return Ok(Vec::new());
    }
    let value = match &setting.value {
        toml::Value::Boolean(true) => return Ok(vec![format!("--{key}")]),
        toml::Value::Boolean(false) => return Ok(Vec::new()),
        toml::Value::Array(items) => {
            let parts: Option<Vec<String>> = items.iter().map(scalar).collect();
            parts
                .ok_or_else(|| bad("a list of numbers or names"))?
                .join(",")
        }
        v => scalar(v).ok_or_else(|| bad("a number, a string, true/false or a list"))?,
    };
    let value = if key == "env" {
        let path = file.folder().join(&value);
        if !path.is_file() {
            return Err(bad(&format!("no environment map {}", path.display())));
        }
        path.to_string_lossy().into_owned()
    } else {
        value
    };
    Ok(vec![format!("--{key}={value}")])
}

/// Parses one setting's flag alone (beside a placeholder scene), so that a bad value
/// is reported at its place in the file with the flag parser's own words.
fn check_alone(
    file: &SceneFile,
    setting: &Setting,
    section: &str,
    args: &[String],
) -> Result<(), SceneFileError> {
    if args.is_empty() {
        return Ok(());
    }
    let argv = ["render", "scene.obj"]
        .into_iter()
        .map(String::from)
        .chain(args.iter().cloned());
    // Flags that need another (--env-scale needs --env) are checked for their value only.
    match render_command().try_get_matches_from(argv) {
        Ok(_) => Ok(()),
        Err(e) if e.kind() == clap::error::ErrorKind::MissingRequiredArgument => Ok(()),
        Err(e) => {
            let text = e.render().to_string();
            let first = text
                .lines()
                .next()
                .unwrap_or("invalid value")
                .trim_start_matches("error: ");
            Err(file.error(
                setting.span.clone(),
                &format!("{section}.{}", setting.key),
                first,
            ))
        }
    }
}
