//! The space of scene options that the combination test covers, generated as a product of its
//! axes (never listed by hand), and the scene text of each cell.

use std::fmt::Write;

/// The compositing modes of `[render] compositing`.
pub const MODES: [&str; 6] = ["dvr", "mip", "minip", "average", "iso", "pathtrace"];

/// Where the cell's render settings are written: the shared `[render]` table; the view's own
/// `render` table over a shared one that says something else in every key; or the shared
/// table for every key but the compositing mode, which the view's table gives (over another).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    Shared,
    Own,
    Inherited,
}

pub const PLACEMENTS: [Placement; 3] = [Placement::Shared, Placement::Own, Placement::Inherited];

/// The volumes beside the primary one.
pub const ROLE_SETS: [&[Role]; 5] =
    [&[], &[Role::Mask], &[Role::Tag], &[Role::Additional], &[Role::Additional, Role::Additional]];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Mask,
    Tag,
    Additional,
}

/// Shading off, or on with this many lights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lighting {
    Off,
    Lights(usize),
}

pub const LIGHTINGS: [Lighting; 4] = [Lighting::Off, Lighting::Lights(0), Lighting::Lights(1), Lighting::Lights(3)];

/// One combination of options.
#[derive(Clone, Copy, Debug)]
pub struct Cell {
    pub mode: &'static str,
    pub placement: Placement,
    pub roles: &'static [Role],
    pub slice: bool,
    pub lighting: Lighting,
    pub skipping: bool,
    pub probe: bool,
}

impl Cell {
    /// Every cell: the product of every axis, the volume set outermost (cells that share it
    /// share loaded volumes), then skipping (which changes what is loaded with them).
    pub fn all() -> Vec<Cell> {
        let mut cells = Vec::new();
        for roles in ROLE_SETS {
            for skipping in [true, false] {
                for mode in MODES {
                    for placement in PLACEMENTS {
                        for slice in [false, true] {
                            // The path tracer never skips (the key changes nothing) and a slice
                            // view composites its scene by DVR: those cells would repeat others.
                            if mode == "pathtrace" && (slice || !skipping) {
                                continue;
                            }
                            for lighting in LIGHTINGS {
                                for probe in [false, true] {
                                    cells.push(Cell { mode, placement, roles, slice, lighting, skipping, probe });
                                }
                            }
                        }
                    }
                }
            }
        }
        cells
    }

    /// The cell as a scene: a head phantom, its other volumes, one 16x16 view.
    pub fn scene(&self) -> String {
        let own = render_table(self.mode, self.lighting, self.skipping);
        let other_mode = if self.mode == "dvr" { "mip" } else { "dvr" };
        let shared = match self.placement {
            Placement::Shared => own.clone(),
            Placement::Own => {
                // Every shared key differs from the view's, so each must be overridden or dropped.
                let other_lighting =
                    if self.lighting == Lighting::Lights(3) { Lighting::Off } else { Lighting::Lights(3) };
                render_table(other_mode, other_lighting, !self.skipping)
            }
            Placement::Inherited => {
                let mut keys = render_table(other_mode, self.lighting, self.skipping);
                keys.retain(|k| !k.starts_with("iso_value"));
                keys
            }
        };
        let mut text = format!("[render]\n{}\n", shared.join("\n"));
        text.push_str(&volumes(self.roles));
        let kind = if self.slice { "kind = \"slice\"\naxis = \"axial\"\nslab = 6.0" } else { "kind = \"raycast\"" };
        write!(text, "\n[[view]]\nname = \"v\"\n{kind}\nsize = [16, 16]\n").expect("a string");
        match self.placement {
            Placement::Shared => {}
            Placement::Own => writeln!(text, "render = {{ {} }}", own.join(", ")).expect("a string"),
            Placement::Inherited => {
                let mode: Vec<&String> =
                    own.iter().filter(|k| k.starts_with("compositing") || k.starts_with("iso_value")).collect();
                let mode: Vec<&str> = mode.iter().map(|k| k.as_str()).collect();
                writeln!(text, "render = {{ {} }}", mode.join(", ")).expect("a string");
            }
        }
        text
    }

    /// The cell in a line, for failure messages.
    pub fn describe(&self) -> String {
        let roles: Vec<String> = self.roles.iter().map(|r| format!("{r:?}").to_lowercase()).collect();
        format!(
            "{} ({:?} render table), volumes [primary{}], {}, {:?}, skipping {}, probe {}",
            self.mode,
            self.placement,
            roles.iter().map(|r| format!(", {r}")).collect::<String>(),
            if self.slice { "slice" } else { "raycast" },
            self.lighting,
            self.skipping,
            self.probe
        )
    }
}

/// The render keys of a mode, a lighting and skipping, as `key = value` lines.
fn render_table(mode: &str, lighting: Lighting, skipping: bool) -> Vec<String> {
    let mut keys = vec![format!("compositing = \"{mode}\"")];
    if mode == "iso" {
        keys.push("iso_value = 0.45".into());
    }
    match lighting {
        Lighting::Off => keys.push("shading = false".into()),
        Lighting::Lights(n) => {
            let names: Vec<String> = ["key", "fill", "back"][..n].iter().map(|l| format!("\"{l}\"")).collect();
            keys.push("shading = true".into());
            keys.push(format!("lights = [{}]", names.join(", ")));
        }
    }
    keys.push(format!("empty_space_skipping = {skipping}"));
    keys
}

/// `[[volume]]` tables: the head phantom as the primary volume, then one volume per role.
pub fn volumes(roles: &[Role]) -> String {
    let mut text =
        "\n[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\ntf = \"ct_bone\"\n".to_string();
    for (i, role) in roles.iter().enumerate() {
        let table = match role {
            Role::Mask => format!("name = \"mask{i}\"\nrole = \"mask\"\nphantom = \"head\""),
            Role::Tag => format!("name = \"tag{i}\"\nrole = \"tag\"\nphantom = \"abdomen\"\ntf = \"labels\""),
            Role::Additional => {
                let tf = ["ct_soft_tissue", "hot_metal"][i % 2];
                format!("name = \"extra{i}\"\nrole = \"additional\"\nphantom = \"abdomen\"\ntf = \"{tf}\"")
            }
        };
        write!(text, "\n[[volume]]\n{table}\n").expect("a string");
    }
    text
}

/// The light-transport options: tone mapping, pre-integration, shadows and ambient occlusion
/// (without shadows), crossed with the modes, view kinds, shading (one light) and an additional
/// volume.
#[derive(Clone, Copy, Debug)]
pub struct LightCell {
    pub tone_mapping: &'static str,
    /// `preintegration`'s value as written: `false`, `true` or `"lighting"`.
    pub preintegration: &'static str,
    pub shadows: &'static str,
    pub occlusion: bool,
    pub mode: &'static str,
    pub slice: bool,
    pub shading: bool,
    pub additional: bool,
}

/// Whether the path tracer is crossed with these light options: of them it uses tone mapping
/// only (pre-integration, shadows and ambient occlusion have no effect on it, W0701, and a slice
/// view composites its scene by DVR), so its cells are those without them, which keeps the
/// matrix from compiling its large shaders for settings that change nothing.
fn traced_light(preintegration: &str, shadows: &str, occlusion: bool, slice: bool) -> bool {
    preintegration == "false" && shadows == "off" && !occlusion && !slice
}

impl LightCell {
    pub fn all() -> Vec<LightCell> {
        let mut cells = Vec::new();
        for additional in [false, true] {
            // "exposure" meters automatically: its operator is a clip, the metering is the risk.
            for tone_mapping in ["off", "exposure", "reinhard", "aces"] {
                for preintegration in ["false", "true", "\"lighting\""] {
                    let lighting = [("off", false), ("rays", false), ("volume", false), ("off", true)];
                    for (shadows, occlusion) in lighting {
                        for mode in MODES {
                            for slice in [false, true] {
                                for shading in [false, true] {
                                    // Its lighting needs shaded DVR: elsewhere it is `true`.
                                    if preintegration == "\"lighting\"" && !(shading && mode == "dvr") {
                                        continue;
                                    }
                                    if mode == "pathtrace" && !traced_light(preintegration, shadows, occlusion, slice) {
                                        continue;
                                    }
                                    cells.push(LightCell {
                                        tone_mapping,
                                        preintegration,
                                        shadows,
                                        occlusion,
                                        mode,
                                        slice,
                                        shading,
                                        additional,
                                    });
                                }
                            }
                        }
                    }
                }
            }
        }
        cells
    }

    /// Why `build` refuses the cell, for exactly the cells it refuses: shadows (rays or a light
    /// volume) and ambient occlusion need shading, and every other combination renders.
    pub fn refusal(&self) -> Option<&'static str> {
        match (self.shadows != "off", self.occlusion, self.shading) {
            (true, _, false) => Some("shadows without shading"),
            (_, true, false) => Some("ambient occlusion without shading"),
            _ => None,
        }
    }

    pub fn scene(&self) -> String {
        let mut render = vec![format!("compositing = \"{}\"", self.mode), format!("shading = {}", self.shading)];
        if self.mode == "iso" {
            render.push("iso_value = 0.45".into());
        }
        render.push(format!("tone_mapping = \"{}\"", self.tone_mapping));
        if self.tone_mapping == "exposure" {
            render.push("auto_exposure = true".into());
        }
        render.push(format!("preintegration = {}", self.preintegration));
        if self.shadows != "off" {
            render.push(format!("shadows = \"{}\"", self.shadows));
        }
        if self.occlusion {
            render.push("ambient_occlusion = true".into());
        }
        let roles: &[Role] = if self.additional { &[Role::Additional] } else { &[] };
        let kind = if self.slice { "kind = \"slice\"\naxis = \"axial\"\nslab = 6.0" } else { "kind = \"raycast\"" };
        // A light from above the head and the right, so that shadows fall somewhere.
        let uniforms = if self.shading { "[uniforms]\nlight_dir_key = [0.3, 0.2, 1.0]\n" } else { "" };
        format!(
            "[render]\n{}\n{}\n{uniforms}\n[[view]]\nname = \"v\"\n{kind}\nsize = [16, 16]\n",
            render.join("\n"),
            volumes(roles)
        )
    }

    pub fn describe(&self) -> String {
        format!("{self:?}")
    }
}

/// The mesh sets of the mesh matrix: none, an opaque needle through the head, the needle with a
/// translucent sphere, a needle that follows a uniform of a user module (the ablation example's
/// pattern), and a second (slice) view shown on its plane with the needle in both.
pub const MESH_SETS: [&str; 5] = ["none", "needle", "needle+translucent", "following", "planes"];

/// Meshes with the options they meet: mesh set, mode, view kind, shading, tone mapping and an
/// additional volume.
#[derive(Clone, Copy, Debug)]
pub struct MeshCell {
    pub meshes: &'static str,
    pub mode: &'static str,
    pub slice: bool,
    pub shading: bool,
    pub tone_mapping: bool,
    pub additional: bool,
}

impl MeshCell {
    pub fn all() -> Vec<MeshCell> {
        let mut cells = Vec::new();
        for additional in [false, true] {
            for meshes in MESH_SETS {
                for mode in MODES {
                    for slice in [false, true] {
                        for shading in [false, true] {
                            for tone_mapping in [false, true] {
                                // The path tracer with meshes: its primary rays end at them. Its
                                // tone mapping and additional volumes are crossed in the other
                                // matrices, and a slice view composites its scene by DVR.
                                if mode == "pathtrace" && (slice || tone_mapping || additional) {
                                    continue;
                                }
                                cells.push(MeshCell { meshes, mode, slice, shading, tone_mapping, additional });
                            }
                        }
                    }
                }
            }
        }
        cells
    }

    pub fn scene(&self) -> String {
        let mut render = vec![format!("compositing = \"{}\"", self.mode), format!("shading = {}", self.shading)];
        if self.mode == "iso" {
            render.push("iso_value = 0.45".into());
        }
        if self.tone_mapping {
            render.push("tone_mapping = \"reinhard\"".into());
        }
        let roles: &[Role] = if self.additional { &[Role::Additional] } else { &[] };
        let kind = if self.slice { "kind = \"slice\"\naxis = \"axial\"\nslab = 6.0" } else { "kind = \"raycast\"" };
        let needle = |tip: &str| {
            format!(
                "\n[[mesh]]\nname = \"needle\"\nshape = \"needle\"\ntip = {tip}\ndirection = [0.3, 0.2, 1.0]\nradius = 1.5\n"
            )
        };
        let meshes = match self.meshes {
            "none" => String::new(),
            "needle" => needle("[2.0, 1.0, 0.0]"),
            "needle+translucent" => {
                needle("[2.0, 1.0, 0.0]")
                    + "\n[[mesh]]\nname = \"ball\"\nshape = \"sphere\"\ncentre = [-4.0, 0.0, 2.0]\nradius = 5.0\nopacity = 0.4\n"
            }
            "following" => needle("\"target\"") + "\n[[module]]\npath = \"target.vrs\"\n",
            _ => needle("[2.0, 1.0, 0.0]"),
        };
        // The second view comes after `v`, which stays view 0.
        let (planes, second) = match self.meshes {
            "planes" if !self.slice => (
                "planes = [\"s\"]\n",
                "\n[[view]]\nname = \"s\"\nkind = \"slice\"\naxis = \"coronal\"\nsize = [16, 16]\n",
            ),
            _ => ("", ""),
        };
        format!(
            "[render]\n{}\n{}{meshes}\n[[view]]\nname = \"v\"\n{kind}\nsize = [16, 16]\n{planes}{second}",
            render.join("\n"),
            volumes(roles)
        )
    }

    /// The user module of the `following` set: a uniform the needle's tip follows.
    pub const TARGET_MODULE: &'static str = "/// Where the needle points (patient space, mm).\npipeline mark_target after compositing.alpha {\n    \
        uniform target: vec3f = vec3f(2.0, 1.0, 0.0) in -50.0 .. 50.0;\n    state src: vec4f;\n\n    \
        state.src = state.src * select(1.0, 0.9, target.x > 100.0);\n}\n";

    pub fn describe(&self) -> String {
        format!("{self:?}")
    }
}
