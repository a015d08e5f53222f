//! `ember render SCENE.toml`: a scene file's settings, cameras and environment read as
//! the flags of the same names. The file's flags come first and the command line's
//! after them, and a later flag overrides an earlier one, so the command line wins.
//!
//! The file is strict everywhere: every key of every table (used by this run or not,
//! such as a camera not rendered or an `[environment]` a `--env` replaces) must be a
//! known key of its table, of the type its flag takes, with a value the flag's own
//! parser accepts; and every error, a setting's companion missing or a conflict
//! between two settings included, is reported at its line and column.

use std::any::TypeId;
use std::ffi::OsString;
use std::ops::Range;

use anyhow::Result;
use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{Arg, ArgMatches, Args, Command, FromArgMatches};
use glam::Vec3;

use super::args::RenderArgs;
use super::plan::CameraChoice;
use ember::scene::{SceneFile, SceneFileError, Setting};

/// Keys of a `[camera.NAME]` table; `camera` names a camera of the glTF files the scene
/// places, which the table's other keys override.
const CAMERA_KEYS: [&str; 8] = [
    "camera",
    "eye",
    "look-at",
    "up",
    "fov",
    "ortho-height",
    "aperture",
    "focus-distance",
];
/// The flags that override a model file's camera, and the image's size (which its
/// aspect ratio completes): (flag, clap id).
const GIVEN: [(&str, &str); 7] = [
    ("eye", "eye"),
    ("look-at", "look_at"),
    ("up", "up"),
    ("fov", "fov"),
    ("ortho-height", "ortho_height"),
    ("width", "width"),
    ("height", "height"),
];
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

/// The camera choice of a command line without a scene file (`user`, the arguments
/// after `render`): `--camera` names a camera of the model file (its first without),
/// and the flags given override it.
pub fn model_camera_choice(user: &[OsString]) -> Result<CameraChoice> {
    let argv = std::iter::once(OsString::from("render")).chain(user.iter().cloned());
    let matches = render_command().try_get_matches_from(argv)?;
    Ok(CameraChoice {
        name: matches.get_one::<String>("camera").cloned(),
        first: true,
        named_at: None,
        given: given_flags(&matches),
    })
}

/// Which of [`GIVEN`]'s flags `matches` has from its command line (a scene file's
/// flags are on it too).
fn given_flags(matches: &ArgMatches) -> Vec<&'static str> {
    GIVEN
        .into_iter()
        .filter(|(_, id)| user_gave(matches, id))
        .map(|(flag, _)| flag)
        .collect()
}

/// One checked setting: where it was written and the flags it stands for.
struct Flag<'f> {
    setting: &'f Setting,
    /// `render.spp`, `camera.top.eye`: the key as errors name it.
    key: String,
    args: Vec<String>,
}

/// The render's arguments: the scene file's flags, then `user` (the command line's
/// arguments after `render`, the scene file among them); and the camera chosen among
/// those of the glTF files the scene places, if any.
pub fn render_args(file: &SceneFile, user: &[OsString]) -> Result<(RenderArgs, CameraChoice)> {
    let command = render_command();
    let argv = |flags: &[Flag]| {
        std::iter::once(OsString::from("render"))
            .chain(flags.iter().flat_map(|f| f.args.iter().map(OsString::from)))
            .chain(user.iter().cloned())
            .collect::<Vec<_>>()
    };
    let given = command.clone().try_get_matches_from(argv(&[]))?;
    // Every table is checked, whether this run uses it or not.
    let render = checked(file, &command, &file.render, "render", None)?;
    let environment = checked(
        file,
        &command,
        &file.environment,
        "environment",
        Some(&ENVIRONMENT_KEYS),
    )?;
    let mut cameras = std::collections::BTreeMap::new();
    for (name, settings) in &file.cameras {
        let table = format!("camera.{name}");
        let flags = checked(file, &command, settings, &table, Some(&CAMERA_KEYS))?;
        cameras.insert(name.clone(), flags);
    }
    let chosen = chosen_camera(file, &given)?;
    let mut used = render;
    // A sky on the command line replaces the file's whole environment.
    if !(user_gave(&given, "env") || user_gave(&given, "background")) {
        used.extend(environment);
    }
    if let Some(flags) = chosen.table().and_then(|name| cameras.remove(name)) {
        used.extend(flags);
    }
    let matches = command
        .try_get_matches_from(argv(&used))
        .map_err(|e| locate(file, &used, e))?;
    let args = RenderArgs::from_arg_matches(&matches)?;
    Ok((args, chosen.choice(file, given_flags(&matches))))
}

/// The camera of a scene file's render.
enum Chosen {
    /// A `[camera.NAME]` table.
    Table(String),
    /// A camera of the glTF files the scene places, by name or index, and where the
    /// file named it (`None`: on the command line).
    Model {
        name: String,
        at: Option<(String, Range<usize>)>,
    },
    /// None named: the glTF files' first camera, else the automatic one.
    Default,
}

impl Chosen {
    fn table(&self) -> Option<&str> {
        match self {
            Chosen::Table(name) => Some(name),
            _ => None,
        }
    }

    /// What the render asks of the glTF files' cameras, `given` the flags that
    /// override them: a table's `camera`, the one named, or their first.
    fn choice(self, file: &SceneFile, given: Vec<&'static str>) -> CameraChoice {
        let (name, first, named_at) = match self {
            Chosen::Table(table) => {
                let key = file.cameras[&table].iter().find(|s| s.key == "camera");
                match key {
                    Some(s) => (
                        model_camera_name(&s.value),
                        false,
                        Some((format!("camera.{table}.camera"), s.span.clone())),
                    ),
                    None => (None, false, None),
                }
            }
            Chosen::Model { name, at } => (Some(name), false, at),
            Chosen::Default => (None, true, None),
        };
        CameraChoice {
            name,
            first,
            named_at,
            given,
        }
    }
}

/// A glTF camera's name, or its index as a number.
fn model_camera_name(value: &toml::Value) -> Option<String> {
    match value {
        toml::Value::String(name) => Some(name.clone()),
        toml::Value::Integer(i) if *i >= 0 => Some(i.to_string()),
        _ => None,
    }
}

fn user_gave(matches: &ArgMatches, id: &str) -> bool {
    matches.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
}

/// The flags of one table's settings, each checked: a key of the table (`keys`, or for
/// `[render]` any flag that is not about the camera, the sky or one run), a value of
/// the type the flag takes, accepted by the flag's parser.
fn checked<'f>(
    file: &'f SceneFile,
    command: &Command,
    settings: &'f [Setting],
    table: &str,
    keys: Option<&[&str]>,
) -> Result<Vec<Flag<'f>>, SceneFileError> {
    let mut flags = Vec::with_capacity(settings.len());
    for setting in settings {
        let name = setting.key.as_str();
        let key = format!("{table}.{name}");
        let bad = |message: &str| file.error(setting.span.clone(), &key, message);
        let arg = command.get_arguments().find(|a| a.get_long() == Some(name));
        let message = match (keys, arg) {
            (Some(keys), _) if !keys.contains(&name) => Some(format!(
                "unknown key `{name}` (the keys of [{table}] are {})",
                keys.join(", ")
            )),
            (None, _)
                if name != "camera"
                    && (CAMERA_KEYS.contains(&name) || ENVIRONMENT_KEYS.contains(&name)) =>
            {
                Some(format!(
                    "`{name}` belongs in a [camera.NAME] table or in [environment]"
                ))
            }
            (None, _) if RUN_ONLY.contains(&name) => Some(format!(
                "`{name}` is about one run: give --{name} on the command line"
            )),
            (None, _) if name == "scene" || arg.is_none() => Some(format!(
                "unknown setting `{name}` (the keys of [render] are ember render's flags)"
            )),
            _ => None,
        };
        if let Some(message) = message {
            return Err(bad(&message));
        }
        let arg = arg.expect("a known key is a flag");
        let args = if name == "camera" {
            // The camera is chosen by name (`chosen_camera`), not repeated as a flag.
            if table == "render" {
                camera_name(file, setting)?;
            } else if model_camera_name(&setting.value).is_none() {
                let message = "takes the name of a camera of the glTF files the scene \
                               places, in quotes, or its index from 0";
                return Err(bad(message));
            }
            Vec::new()
        } else {
            flag_args(file, setting, arg).map_err(|m| bad(&m))?
        };
        check_alone(&args).map_err(|m| bad(&m))?;
        flags.push(Flag { setting, key, args });
    }
    Ok(flags)
}

/// What TOML value a flag's setting takes.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// `true` gives the flag, `false` leaves it out.
    Switch,
    Number,
    /// A list of this many numbers: a vector `[x, y, z]`, a pixel `[x, y]`.
    Numbers(usize),
    /// A list of names (the flag's comma-separated values), or one name.
    Names,
    /// A string: a name or a path.
    Text,
}

impl Kind {
    fn of(arg: &Arg) -> Kind {
        if !arg.get_action().takes_values() {
            return Kind::Switch;
        }
        if arg.get_value_delimiter().is_some() {
            return Kind::Names;
        }
        let id = arg.get_value_parser().type_id();
        let is = |t: TypeId| id == t;
        if is(TypeId::of::<Vec3>()) {
            Kind::Numbers(3)
        } else if is(TypeId::of::<(u32, u32)>()) {
            Kind::Numbers(2)
        } else if [
            TypeId::of::<u32>(),
            TypeId::of::<u64>(),
            TypeId::of::<f32>(),
            TypeId::of::<f64>(),
        ]
        .into_iter()
        .any(is)
        {
            Kind::Number
        } else {
            Kind::Text
        }
    }

    fn describe(self) -> String {
        match self {
            Kind::Switch => "a switch: true or false".into(),
            Kind::Number => "a number".into(),
            Kind::Numbers(n) => format!("a list of {n} numbers"),
            Kind::Names => "a name in quotes, or a list of them".into(),
            Kind::Text => "a string in quotes".into(),
        }
    }
}

/// The command-line arguments of one setting: `--key=value`, `--key` for a switch set
/// to `true`, nothing for `false`, lists comma-separated; `env` resolved against the
/// file. The error names the type the flag takes when the value is not of it.
fn flag_args(file: &SceneFile, setting: &Setting, arg: &Arg) -> Result<Vec<String>, String> {
    use toml::Value as V;
    let key = &setting.key;
    let kind = Kind::of(arg);
    let number = |v: &V| match v {
        V::Integer(i) => Some(i.to_string()),
        V::Float(f) => Some(f.to_string()),
        _ => None,
    };
    let text = |v: &V| match v {
        V::String(s) => Some(s.clone()),
        _ => None,
    };
    let list = |items: &[V], each: &dyn Fn(&V) -> Option<String>| {
        items.iter().map(each).collect::<Option<Vec<_>>>()
    };
    let value = match (kind, &setting.value) {
        (Kind::Switch, V::Boolean(true)) => return Ok(vec![format!("--{key}")]),
        (Kind::Switch, V::Boolean(false)) => return Ok(Vec::new()),
        (Kind::Number, v) => number(v),
        (Kind::Numbers(n), V::Array(items)) if items.len() == n => {
            list(items, &number).map(|v| v.join(","))
        }
        (Kind::Names, V::Array(items)) if !items.is_empty() => {
            list(items, &text).map(|v| v.join(","))
        }
        (Kind::Names | Kind::Text, v) => text(v),
        _ => None,
    };
    let Some(value) = value else {
        let given = match &setting.value {
            V::Boolean(b) => format!("{b}"),
            V::Array(items) => format!("a list of {}", items.len()),
            V::Table(_) => "a table".into(),
            V::String(s) => format!("the string {s:?}"),
            V::Integer(_) | V::Float(_) => "a number".into(),
            V::Datetime(_) => "a date".into(),
        };
        return Err(format!("takes {}, not {given}", kind.describe()));
    };
    if key == "env" {
        let path = file.folder().join(&value);
        // The map is read later; what cannot be read is refused here, at its line.
        ember::io::InputFile::open(&path).map_err(|e| e.to_string())?;
        return Ok(vec![format!("--{key}={}", path.to_string_lossy())]);
    }
    Ok(vec![format!("--{key}={value}")])
}

/// Parses one setting's flags alone (beside a placeholder scene), so that a bad value
/// is reported at its place in the file with the flag parser's own words. A flag that
/// needs another (`env-scale` needs `env`) is checked here for its value only, and
/// for its companion once all flags are together ([`locate`]).
fn check_alone(args: &[String]) -> Result<(), String> {
    if args.is_empty() {
        return Ok(());
    }
    match parse_alone(args) {
        Ok(_) => Ok(()),
        Err(e) if e.kind() == ErrorKind::MissingRequiredArgument => Ok(()),
        Err(e) => {
            let text = e.render().to_string();
            let first = text.lines().next().unwrap_or("invalid value");
            Err(first.trim_start_matches("error: ").to_owned())
        }
    }
}

fn parse_alone(args: &[String]) -> Result<ArgMatches, clap::Error> {
    let argv = ["render", "scene.obj"]
        .into_iter()
        .map(String::from)
        .chain(args.iter().cloned());
    render_command().try_get_matches_from(argv)
}

/// The error of parsing the file's flags with the command line's, at the place of the
/// file's setting it is about: one that needs a companion no one gave, or that
/// conflicts with another. Errors of the command line alone stay clap's.
fn locate(file: &SceneFile, used: &[Flag], error: clap::Error) -> anyhow::Error {
    let long = |s: &str| -> String {
        let s = s.trim_start_matches('-');
        s.split([' ', '=']).next().unwrap_or(s).to_owned()
    };
    let names = |kind: ContextKind| -> Vec<String> {
        match error.get(kind) {
            Some(ContextValue::String(s)) => vec![long(s)],
            Some(ContextValue::Strings(v)) => v.iter().map(|s| long(s)).collect(),
            _ => Vec::new(),
        }
    };
    let in_file = |name: &str| {
        used.iter()
            .find(|f| f.setting.key == name && !f.args.is_empty())
    };
    let at = |flag: &Flag, message: String| -> anyhow::Error {
        file.error(flag.setting.span.clone(), &flag.key, &message)
            .into()
    };
    match error.kind() {
        ErrorKind::ArgumentConflict => {
            let (this, prior) = (names(ContextKind::InvalidArg), names(ContextKind::PriorArg));
            let (Some(a), Some(b)) = (this.first(), prior.first()) else {
                return error.into();
            };
            // The later of the two in the file; a file's setting against a flag of
            // the command line is the file's.
            let blame = match (in_file(a), in_file(b)) {
                (Some(x), Some(y)) if x.setting.span.start < y.setting.span.start => Some((y, a)),
                (Some(x), Some(_)) => Some((x, b)),
                (Some(x), None) => Some((x, b)),
                (None, Some(y)) => Some((y, a)),
                (None, None) => None,
            };
            match blame {
                Some((flag, other)) => {
                    let message = format!("cannot be given with `{other}`: give one of them");
                    at(flag, message)
                }
                None => error.into(),
            }
        }
        ErrorKind::MissingRequiredArgument => {
            let missing = names(ContextKind::InvalidArg);
            let requirer = used.iter().find(|flag| {
                !flag.args.is_empty()
                    && parse_alone(&flag.args).is_err_and(|e| {
                        e.kind() == ErrorKind::MissingRequiredArgument
                            && missing.iter().any(|m| {
                                matches!(e.get(ContextKind::InvalidArg),
                                    Some(ContextValue::Strings(v)) if v.iter().any(|s| long(s) == *m))
                            })
                    })
            });
            match requirer {
                Some(flag) => {
                    let needs: Vec<String> = missing.iter().map(|m| format!("`{m}`")).collect();
                    at(flag, format!("needs {} beside it", needs.join(" and ")))
                }
                None => error.into(),
            }
        }
        _ => error.into(),
    }
}

/// The camera `[render] camera` names: a `[camera.NAME]` table, else a camera of the
/// glTF files the scene places, by name or index (checked once they are loaded).
fn camera_name(file: &SceneFile, setting: &Setting) -> Result<Chosen, SceneFileError> {
    match &setting.value {
        toml::Value::String(name) if file.cameras.contains_key(name) => {
            Ok(Chosen::Table(name.clone()))
        }
        value => match model_camera_name(value) {
            Some(name) => Ok(Chosen::Model {
                name,
                at: Some(("render.camera".to_owned(), setting.span.clone())),
            }),
            None => Err(file.error(
                setting.span.clone(),
                "render.camera",
                "takes the name of a [camera.NAME] table or of a glTF camera, in quotes, or a \
                 glTF camera's index from 0",
            )),
        },
    }
}

/// `--camera NAME`, else `[render] camera = "NAME"`, else the file's only camera table;
/// a name that is no table names a camera of the glTF files the scene places. Without
/// tables, the glTF files' first camera (or the automatic one).
fn chosen_camera(file: &SceneFile, given: &ArgMatches) -> Result<Chosen> {
    let names: Vec<&str> = file.cameras.keys().map(String::as_str).collect();
    if let Some(name) = given.get_one::<String>("camera") {
        return Ok(match file.cameras.contains_key(name) {
            true => Chosen::Table(name.clone()),
            false => Chosen::Model {
                name: name.clone(),
                at: None,
            },
        });
    }
    if let Some(setting) = file.render.iter().find(|s| s.key == "camera") {
        return Ok(camera_name(file, setting)?);
    }
    match names.as_slice() {
        [] => Ok(Chosen::Default),
        [only] => Ok(Chosen::Table(only.to_string())),
        _ => {
            let message = format!(
                "the file has cameras {}: choose one with --camera NAME or [render] camera = \
                 \"NAME\"",
                names.join(", ")
            );
            Err(file.error(0..0, "render.camera", &message).into())
        }
    }
}
