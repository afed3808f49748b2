//! `import "name"` in a script: only `name.rhai` in the script's own folder
//! or in the shipped scripts' folder (`experiments/scripts/`), in that
//! order. A module name is a file stem — letters, digits, `_` and `-`, with
//! an optional `.rhai` — so `..`, `/`, absolute paths and other folders are
//! refused; a module file that is a symbolic link leading out of its folder
//! is refused too. Modules are read as scripts are ([`read_script`]: a
//! regular file, size-capped) and run under the same limits.

use std::path::{Path, PathBuf};

use rhai::{Engine, EvalAltResult, Module, ModuleResolver, Position, Scope, Shared};

use super::limits::read_script;

/// The shipped scripts' folder.
pub fn shipped_folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts")
}

/// Resolves `import` from the allowed folders only.
pub struct Modules {
    /// The folders searched, in order.
    folders: Vec<PathBuf>,
}

impl Modules {
    /// Imports for the script `file`: its folder, then the shipped scripts'.
    pub fn for_script(file: &Path) -> Self {
        let own = match file.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Self {
            folders: vec![own, shipped_folder()],
        }
    }

    /// The file `name` names, or why it is refused.
    fn find(&self, name: &str) -> Result<PathBuf, String> {
        let stem = name.strip_suffix(".rhai").unwrap_or(name);
        let plain = !stem.is_empty()
            && stem.len() <= 64
            && stem
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        let list = || {
            self.folders
                .iter()
                .map(|f| f.display().to_string())
                .collect::<Vec<_>>()
                .join(" or ")
        };
        if !plain {
            return Err(format!(
                "import \"{name}\": a module is named by its file stem (letters, digits, \
                 `_`, `-`) and read from {} only",
                list()
            ));
        }
        for folder in &self.folders {
            let file = folder.join(format!("{stem}.rhai"));
            if std::fs::symlink_metadata(&file).is_err() {
                continue;
            }
            let inside = match (file.canonicalize(), folder.canonicalize()) {
                (Ok(f), Ok(d)) => f.parent() == Some(d.as_path()),
                _ => false,
            };
            if !inside {
                return Err(format!(
                    "import \"{name}\": {} leads out of its folder; modules are read from {} only",
                    file.display(),
                    list()
                ));
            }
            return Ok(file);
        }
        Err(format!("import \"{name}\": no {stem}.rhai in {}", list()))
    }
}

impl ModuleResolver for Modules {
    fn resolve(
        &self,
        engine: &Engine,
        _source: Option<&str>,
        path: &str,
        pos: Position,
    ) -> Result<Shared<Module>, Box<EvalAltResult>> {
        let in_module =
            |e: Box<EvalAltResult>| Box::new(EvalAltResult::ErrorInModule(path.into(), e, pos));
        let file = self
            .find(path)
            .map_err(|m| EvalAltResult::ErrorRuntime(m.into(), pos))?;
        let text = read_script(&file, "module")
            .map_err(|e| EvalAltResult::ErrorRuntime(e.to_string().into(), pos))?;
        let mut ast = engine.compile(text).map_err(|e| in_module(e.into()))?;
        ast.set_source(file.display().to_string());
        let module = Module::eval_ast_as_new(Scope::new(), &ast, engine).map_err(in_module)?;
        Ok(module.into())
    }
}
