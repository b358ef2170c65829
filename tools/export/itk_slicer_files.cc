#include "tools/export/itk_slicer_files.h"

#include <filesystem>
#include <mutex>

// Debian's ITK carries its own Eigen under Eigen's include guards: the
// system's comes first so that ITK's defers to it.
#include <Eigen/Dense>
#include <itkAffineTransform.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOBase.h>
#include <itkImageIOFactory.h>
#include <itkTransformFileWriter.h>
#include <itkTxtTransformIOFactory.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"

namespace dg::tools {
namespace {

// ITK finds transform IO only through registered factories, as it finds
// image IO (io/ct/itk_factories.h says why none is registered by itself).
void RegisterItkTextTransformIo() {
  static std::once_flag once;
  std::call_once(once, [] { itk::TxtTransformIOFactory::RegisterOneFactory(); });
}

template <typename Pixel>
ImageGeometryMm Rewrite(const std::string& image, const std::string& out_mhd) {
  using Image = itk::Image<Pixel, 3>;
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName(image);
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("ITK cannot read the CT: ") + e.GetDescription(), image,
                "give a MetaImage, NRRD or NIfTI volume in the scene's preoperative: {ct: ...}");
  }
  // The reader's notes (its IO's name, the original direction) would be
  // written as header keys of their own: the header keeps the geometry only.
  reader->GetOutput()->SetMetaDataDictionary(itk::MetaDataDictionary());
  auto writer = itk::ImageFileWriter<Image>::New();
  writer->SetFileName(out_mhd);
  writer->SetInput(reader->GetOutput());
  writer->SetUseCompression(false);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("ITK cannot write the CT: ") + e.GetDescription(), out_mhd,
                "check that the output folder is writable and its file system has free space");
  }
  const Image& written = *reader->GetOutput();
  ImageGeometryMm geometry;
  for (int a = 0; a < 3; ++a) {
    geometry.size[a] = static_cast<int>(written.GetLargestPossibleRegion().GetSize()[a]);
    geometry.spacing_mm[a] = written.GetSpacing()[a];
    geometry.origin_mm[a] = written.GetOrigin()[a];
    for (int b = 0; b < 3; ++b) geometry.direction(a, b) = written.GetDirection()(a, b);
  }
  return geometry;
}

}  // namespace

void WriteItkAffineTransform(const std::string& path, const Eigen::Matrix4d& T_mm) {
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension != ".tfm" && extension != ".txt") {
    throw Error("an ITK text transform file must end in .tfm or .txt", path, "name the file FILE.tfm");
  }
  RegisterItkTextTransformIo();
  using Affine = itk::AffineTransform<double, 3>;
  auto transform = Affine::New();
  Affine::MatrixType matrix;
  Affine::OutputVectorType translation;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) matrix(r, c) = T_mm(r, c);
    translation[r] = T_mm(r, 3);
  }
  transform->SetMatrix(matrix);
  transform->SetTranslation(translation);  // centre 0: translation and offset agree

  auto writer = itk::TransformFileWriterTemplate<double>::New();
  writer->SetFileName(path);
  writer->SetInput(transform);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("ITK cannot write the transform: ") + e.GetDescription(), path,
                "check that the output folder is writable and its file system has free space");
  }
}

ImageGeometryMm RewriteAsMetaImage(const std::string& image, const std::string& out_mhd) {
  io::RegisterItkImageIo();
  const itk::ImageIOBase::Pointer io =
      itk::ImageIOFactory::CreateImageIO(image.c_str(), itk::ImageIOFactory::ReadMode);
  if (!io) {
    throw Error("ITK has no reader for the CT", image,
                "give a MetaImage (.mhd/.mha), NRRD or NIfTI volume in the scene's preoperative: {ct: ...}");
  }
  io->SetFileName(image);
  io->ReadImageInformation();
  using Component = itk::IOComponentEnum;
  switch (io->GetComponentType()) {
    case Component::SHORT: return Rewrite<short>(image, out_mhd);
    case Component::USHORT: return Rewrite<unsigned short>(image, out_mhd);
    case Component::CHAR: return Rewrite<signed char>(image, out_mhd);
    case Component::UCHAR: return Rewrite<unsigned char>(image, out_mhd);
    default: return Rewrite<float>(image, out_mhd);
  }
}

}  // namespace dg::tools
