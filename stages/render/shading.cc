#include "stages/render/shading.h"

namespace dg::stages::render {

std::string Material::Validate() const {
  if (texture != nullptr && (texture->empty() || texture->type() != CV_8UC3))
    return "texture must be a non-empty CV_8UC3 (BGR) image";
  if (!(ambient >= 0 && diffuse >= 0 && specular >= 0 && shininess >= 0))
    return "ambient, diffuse, specular and shininess must be non-negative";
  if (!(color.allFinite() && specular_color.allFinite())) return "colours must be finite";
  return {};
}

}  // namespace dg::stages::render
