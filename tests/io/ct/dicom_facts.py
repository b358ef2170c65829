"""What pydicom reads in DICOM files: the independent truth the CT reader and
writer tests compare with.

usage: dicom_facts.py PATH [--pixels]
PATH is a DICOM file or a folder of them (every file in it, by name). For
each file it prints a line `file NAME`, then one line per tag present,
`KEYWORD v1 v2 ...` (multi-valued tags split), and with --pixels a line
`hu v1 v2 ...`: the pixel data row by row with the rescale applied
(pixel * RescaleSlope + RescaleIntercept), as pydicom decodes it.
"""
import os
import sys

import pydicom

TAGS = [
    "Modality", "PatientID", "StudyInstanceUID", "SeriesInstanceUID", "FrameOfReferenceUID",
    "SOPInstanceUID", "SOPClassUID", "SeriesDescription", "InstanceNumber",
    "ImagePositionPatient", "ImageOrientationPatient", "PixelSpacing", "SliceThickness",
    "Rows", "Columns", "RescaleSlope", "RescaleIntercept",
    "TemporalPositionIdentifier", "NumberOfTemporalPositions", "NominalPercentageOfCardiacPhase",
    "TriggerTime", "HeartRate",
]


def main():
    path = sys.argv[1]
    pixels = "--pixels" in sys.argv[2:]
    files = [os.path.join(path, name) for name in sorted(os.listdir(path))] if os.path.isdir(path) else [path]
    for name in files:
        data = pydicom.dcmread(name)
        print("file", os.path.basename(name))
        for keyword in TAGS:
            if keyword not in data:
                continue
            value = data.data_element(keyword).value
            values = list(value) if isinstance(value, (list, pydicom.multival.MultiValue)) else [value]
            print(keyword, " ".join(str(v).replace(" ", "_") for v in values))
        if pixels:
            slope = float(data.get("RescaleSlope", 1))
            intercept = float(data.get("RescaleIntercept", 0))
            hu = data.pixel_array.astype(float) * slope + intercept
            print("hu", " ".join("%.6g" % v for v in hu.ravel()))


if __name__ == "__main__":
    main()
