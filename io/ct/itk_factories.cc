#include "io/ct/itk_factories.h"

#include <mutex>

#include <itkGDCMImageIOFactory.h>
#include <itkMetaImageIOFactory.h>
#include <itkNiftiImageIOFactory.h>
#include <itkNrrdImageIOFactory.h>

namespace dg::io {

void RegisterItkImageIo() {
  static std::once_flag once;
  std::call_once(once, [] {
    // GDCM last: ITK asks each reader in turn, and GDCM warns on stderr
    // about every file that is not DICOM that it is asked about.
    itk::NiftiImageIOFactory::RegisterOneFactory();
    itk::NrrdImageIOFactory::RegisterOneFactory();
    itk::MetaImageIOFactory::RegisterOneFactory();
    itk::GDCMImageIOFactory::RegisterOneFactory();
  });
}

}  // namespace dg::io
