"""Sets or removes top-level tags in every DICOM file of a folder with pydicom,
as another program would have written them: the phase tags the project's
writer does not write (respiratory ones).

usage: set_dicom_tags.py FOLDER KEYWORD=VALUE ... KEYWORD= ...
KEYWORD is pydicom's keyword (e.g. NominalPercentageOfRespiratoryPhase);
VALUE is written with the keyword's VR from pydicom's dictionary; an empty
VALUE removes the tag.
"""
import os
import sys

import pydicom
from pydicom.datadict import dictionary_VR, tag_for_keyword


def main():
    folder = sys.argv[1]
    changes = [argument.split("=", 1) for argument in sys.argv[2:]]
    for name in sorted(os.listdir(folder)):
        path = os.path.join(folder, name)
        data = pydicom.dcmread(path)
        for keyword, value in changes:
            if value == "":
                if keyword in data:
                    delattr(data, keyword)
                continue
            vr = dictionary_VR(tag_for_keyword(keyword))
            data.add_new(tag_for_keyword(keyword), vr, float(value) if vr in ("FL", "FD") else value)
        data.save_as(path)


if __name__ == "__main__":
    main()
