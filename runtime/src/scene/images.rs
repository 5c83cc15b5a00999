//! The scene's images (`[[image]]`): picture files read and uploaded when the scene's image
//! tables change, and handed to the mesh layers of the views whose trees hold them, on their
//! rectangles in patient space like slice views on their planes.

use super::SceneRenderer;
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::mesh_layer::PlanePicture;
use crate::textures::Image2d;
use glam::{Vec2, Vec3};
use vrsc::scene::{self as vscene, Scene};

/// The scene's images as uploaded, in `Scene::images` order.
#[derive(Default)]
pub(super) struct SceneImages {
    /// The tables they were read from (`{:?}`, resolved paths included).
    key: String,
    pub(super) pictures: Vec<PlanePicture>,
    /// Counts uploads: a view whose planes are images only takes them again when it changes.
    pub(super) generation: u64,
}

impl SceneRenderer {
    /// Reads and uploads every image of `scene` when its image tables changed (a file's
    /// errors are errors here; `build` reports them first, at the path).
    pub(super) fn load_images(&mut self, scene: &Scene) -> Result<(), RuntimeError> {
        let key = format!("{:?}", scene.images);
        if key == self.tree.images.key {
            return Ok(());
        }
        let pictures = scene.images.iter().map(|image| upload(&self.gpu, image)).collect::<Result<Vec<_>, _>>()?;
        let generation = self.tree.images.generation + 1;
        self.tree.images = SceneImages { key, pictures, generation };
        self.resources.content_changed();
        Ok(())
    }
}

/// `image`'s file as a premultiplied `Rgba8Unorm` texture on its rectangle (the colours as the
/// file has them: a view's picture holds display values too).
fn upload(gpu: &Gpu, image: &vscene::Image) -> Result<PlanePicture, RuntimeError> {
    let name = &image.name.name;
    let mut rgba = read_image(image)
        .map_err(|why| RuntimeError::Invalid(format!("image `{name}`: cannot read `{}`: {why}", image.file.given)))?;
    let (w, h) = rgba.dimensions();
    let most = gpu.device.limits().max_texture_dimension_2d;
    if w > most || h > most {
        return Err(RuntimeError::Invalid(format!(
            "image `{name}`: {w} x {h} pixels, more than this device's {most} on a side"
        )));
    }
    premultiply(&mut rgba);
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    let format = wgpu::TextureFormat::Rgba8Unorm;
    let texture =
        Image2d { label: name, size: [w, h], format, usage }.create(gpu, &format!("uploading image `{name}`"))?;
    gpu.queue.write_texture(
        texture.as_image_copy(),
        rgba.as_raw(),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 4), rows_per_image: Some(h) },
        texture.size(),
    );
    Ok(PlanePicture {
        picture: texture.create_view(&Default::default()),
        corners: image.corners().map(Vec3::from),
        uv: [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
    })
}

/// The file's pixels, RGBA with 8 bits a channel (a PNG or a JPEG, known by its contents);
/// the error says why not, for `build` to report at the path.
pub fn read_image(image: &vscene::Image) -> Result<image::RgbaImage, String> {
    decode(&image.file.resolved)
}

fn decode(path: &std::path::Path) -> Result<image::RgbaImage, String> {
    let decoded = image::ImageReader::open(path)
        .and_then(|reader| reader.with_guessed_format())
        .map_err(|e| e.to_string())?
        .decode()
        .map_err(|e| e.to_string())?;
    Ok(decoded.to_rgba8())
}

/// Straight alpha to premultiplied, rounded (the mesh layer's plane pipeline divides it out).
fn premultiply(rgba: &mut image::RgbaImage) {
    for pixel in rgba.pixels_mut() {
        let a = u16::from(pixel[3]);
        for c in &mut pixel.0[..3] {
            *c = ((u16::from(*c) * a + 127) / 255) as u8;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::decode;

    /// A photograph is a JPEG: one (grey, known by its contents though named `.png`) decodes
    /// to its grey within JPEG's error; a file of neither format is refused with the reason.
    #[test]
    fn a_jpeg_decodes_by_its_contents_and_text_is_refused() {
        let dir = tempfile::tempdir().expect("a folder");
        let grey = image::RgbImage::from_pixel(16, 8, image::Rgb([90, 90, 90]));
        let path = dir.path().join("photo.png");
        grey.save_with_format(&path, image::ImageFormat::Jpeg).expect("a JPEG written");
        let decoded = decode(&path).expect("the JPEG decodes");
        assert_eq!(decoded.dimensions(), (16, 8));
        assert!(decoded.pixels().all(|p| p[0].abs_diff(90) <= 2 && p[3] == 255), "{:?}", decoded.get_pixel(0, 0));
        let text = dir.path().join("notes.png");
        std::fs::write(&text, "not a picture").expect("written");
        assert!(decode(&text).is_err());
    }
}
