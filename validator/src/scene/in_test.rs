//! Scenes in unit tests: check a scene file, then go on with the validator
//! that saw its calls, finding its objects by their scene names.

use super::resolve;
use super::{CheckOptions, Scene, SceneError, SceneReport};
use crate::model::Handle;
use crate::Validator;

impl Scene {
    /// Checks the scene's calls, as [`Scene::check`], and returns the
    /// validator that saw them too, holding the scene's device and objects
    /// (buffers with their contents and addresses, built micromaps), so a
    /// test can check more calls against them.
    pub fn check_into_validator(
        &self,
        options: &CheckOptions,
    ) -> Result<(SceneReport, Validator), SceneError> {
        let run = self.run(options)?;
        let checked = run.checked;
        let report = SceneReport {
            path: self.path.clone(),
            calls: checked.calls,
            objects: checked.objects,
            findings: checked.report.findings.clone(),
            report: checked.report,
        };
        Ok((report, run.validator))
    }
}

impl Scene {
    /// Resolves the scene and checks its calls, keeping the validator and
    /// the resolved rays; a semantic problem is the scene's error.
    pub(super) fn run(&self, options: &CheckOptions) -> Result<resolve::Run, SceneError> {
        let mut run = resolve::run(&self.file, &self.base_dir, options).map_err(|p| {
            SceneError::Semantic {
                path: self.path.clone(),
                json_path: p.path,
                message: p.message,
            }
        })?;
        // Each finding points at the scene file and the line its call starts on.
        for finding in &mut run.checked.report.findings {
            finding.at.scene = Some(self.path.clone());
            finding.at.line = finding
                .at
                .call
                .and_then(|call| self.call_lines.get(call))
                .copied();
        }
        Ok(run)
    }
}

impl SceneReport {
    /// The handle the checker gave the object the scene names `name`
    /// (a buffer, micromap, acceleration structure, ...), if there is one.
    pub fn handle(&self, name: &str) -> Option<Handle> {
        self.objects
            .iter()
            .find(|object| object.name == name)
            .map(|object| object.handle)
    }
}
