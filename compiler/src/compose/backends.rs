//! Translating a composed view to the other shading languages through naga's back ends
//! (`vrsc build --emit spirv,glsl,msl,hlsl`).

use naga::back::{glsl, hlsl, msl, spv};

/// An output language besides WGSL.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// SPIR-V binary (`.spv`), for Vulkan.
    Spirv,
    /// GLSL 4.50 (`.comp.glsl`), for OpenGL.
    Glsl,
    /// Metal Shading Language (`.metal`).
    Msl,
    /// HLSL shader model 5.1 (`.hlsl`), for Direct3D 12.
    Hlsl,
}

impl Target {
    /// Every target, in the order `--emit` lists them.
    pub const ALL: [Target; 4] = [Target::Spirv, Target::Glsl, Target::Msl, Target::Hlsl];

    /// The name users write (`--emit spirv`).
    pub fn name(self) -> &'static str {
        match self {
            Target::Spirv => "spirv",
            Target::Glsl => "glsl",
            Target::Msl => "msl",
            Target::Hlsl => "hlsl",
        }
    }

    /// The file extension of this target's output.
    pub fn extension(self) -> &'static str {
        match self {
            Target::Spirv => "spv",
            Target::Glsl => "comp.glsl",
            Target::Msl => "metal",
            Target::Hlsl => "hlsl",
        }
    }
}

impl std::str::FromStr for Target {
    type Err = String;

    fn from_str(s: &str) -> Result<Target, String> {
        Target::ALL.into_iter().find(|t| t.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Target::ALL.iter().map(|t| t.name()).collect();
            format!("unknown target `{s}`; expected one of: {}", names.join(", "))
        })
    }
}

/// Translates a validated module with one compute entry point named `entry`. Errors are naga's
/// messages: a back end may not support something the module uses.
pub fn translate(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    entry: &str,
    target: Target,
) -> Result<Vec<u8>, String> {
    let stage = naga::ShaderStage::Compute;
    match target {
        Target::Spirv => {
            let options = spv::PipelineOptions { shader_stage: stage, entry_point: entry.to_string() };
            let words = spv::write_vec(module, info, &spv::Options::default(), Some(&options)).map_err(err)?;
            Ok(words.iter().flat_map(|w| w.to_le_bytes()).collect())
        }
        Target::Glsl => {
            let options = glsl::Options { version: glsl::Version::Desktop(450), ..Default::default() };
            let pipeline =
                glsl::PipelineOptions { shader_stage: stage, entry_point: entry.to_string(), multiview: None };
            let mut out = String::new();
            let policies = naga::proc::BoundsCheckPolicies::default();
            glsl::Writer::new(&mut out, module, info, &options, &pipeline, policies)
                .map_err(err)?
                .write()
                .map_err(err)?;
            Ok(out.into_bytes())
        }
        Target::Msl => {
            let pipeline = msl::PipelineOptions { entry_point: Some((stage, entry.to_string())), ..Default::default() };
            let (out, _) = msl::write_string(module, info, &msl::Options::default(), &pipeline).map_err(err)?;
            Ok(out.into_bytes())
        }
        Target::Hlsl => {
            let pipeline = hlsl::PipelineOptions { entry_point: Some((stage, entry.to_string())) };
            let options = hlsl::Options::default();
            let mut out = String::new();
            hlsl::Writer::new(&mut out, &options, &pipeline).write(module, info, None).map_err(err)?;
            Ok(out.into_bytes())
        }
    }
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}
