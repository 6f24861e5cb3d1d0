"""Small hand-written trace files, one per supported format, each with the samples it must read as.

Written for these tests from the formats' documented layouts, never copied from a real export.
Every fixture is a ``Fixture``: its file name, text, sibling files (metadata an export puts
beside it), the format detection must find, the reading options it needs, and the expected
trace (times from the first sample, validity, and the valid samples' points).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


def tsv(*rows: str) -> str:
    """Rows written with ``|`` between cells, as tab-separated text."""
    return "".join(row.replace("|", "\t") + "\n" for row in rows)


@dataclass(frozen=True)
class Fixture:
    """One trace file and what it must read as."""

    key: str
    name: str
    text: str
    fmt: str
    t: list[float]
    valid: list[bool]
    x: list[float]
    y: list[float]
    siblings: dict[str, str] = field(default_factory=dict)
    screen_px: tuple[int, int] | None = None
    recording: str | None = None
    invalid: dict[str, int] = field(default_factory=dict)
    skipped: dict[str, int] = field(default_factory=dict)

    def write(self, folder: Path, encoding: str = "utf-8") -> Path:
        """Write the file and its siblings into ``folder``; returns the trace's path."""
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in self.siblings.items():
            (folder / name).write_text(text, encoding="utf-8")
        path = folder / self.name
        path.write_bytes(self.text.encode(encoding))
        return path


NEON_INFO = '{"recording_id": "r1", "module_serial_number": "123456", "frame_name": "Just act natural"}'
INVISIBLE_INFO = '{"recording_id": "r1", "glasses_serial_number": "ab12c", "scene_camera_serial_number": "x9"}'

CLOUD_GAZE_HEADER = (
    "section id,recording id,timestamp [ns],gaze x [px],gaze y [px],worn,fixation id,blink id,"
    "azimuth [deg],elevation [deg]\n"
)
NEON = CLOUD_GAZE_HEADER + (
    "s1,r1,1700000000000000000,800.0,600.0,1.0,1,,0.0,0.0\n"
    "s1,r1,1700000000005000000,400.0,300.0,1.0,1,,-10.0,5.0\n"
    "s1,r1,1700000000010000001,1600.0,1200.0,1.0,,1,20.0,-10.0\n"
    "s1,r1,1700000000015000000,100.0,100.0,0.0,,,,\n"
)
INVISIBLE = CLOUD_GAZE_HEADER + (
    "s1,r1,1600000000000000000,544.0,540.0,1.0,1,,0.0,0.0\ns1,r1,1600000000004000000,272.0,810.0,1.0,1,,1.0,1.0\n"
)
MARKER_MAPPER = (
    "section id,recording id,timestamp [ns],gaze detected on surface,gaze position on surface x [normalized],"
    "gaze position on surface y [normalized],fixation id,blink id\n"
    "s1,r1,1700000000000000000,True,0.5,0.25,1,\n"
    "s1,r1,1700000000005000000,False,1.7,-0.4,,\n"
    "s1,r1,1700000000010000000,true,0.1,0.9,2,\n"
)
REFERENCE_IMAGE = (
    "section id,recording id,timestamp [ns],gaze detected in reference image,"
    "gaze position in reference image x [px],gaze position in reference image y [px],fixation id,blink id\n"
    "s1,r1,1700000000000000000,True,1000,750,1,\n"
    "s1,r1,1700000000005000000,False,,,,\n"
    "s1,r1,1700000000010000000,True,500,1500,1,\n"
)
GAZEPOINT = (
    "MEDIA_ID,MEDIA_NAME,CNT,TIME(2024/01/15 10:00:00.000),TIMETICK(f=10000000),FPOGX,FPOGY,FPOGS,FPOGD,"
    "FPOGID,FPOGV,BPOGX,BPOGY,BPOGV,USER,\n"
    "0,NewMedia0,0,0.00000,1000000,0.50000,0.25000,0.00000,0.01660,1,1,0.50000,0.25000,1,,\n"
    "0,NewMedia0,1,0.01660,1166000,0.60000,0.75000,0.00000,0.03320,1,0,0.60000,0.75000,0,,\n"
    "0,NewMedia0,2,0.03320,1332000,0.10000,0.90000,0.03320,0.01660,2,1,0.10000,0.90000,1,,\n"
)
EYELINK_MONO = (
    "** CONVERTED FROM D:\\data\\sub01.edf using edfapi 4.2.1 Mar 25 2020 on Mon Jan 15 10:00:00 2024\n"
    "** DATE: Mon Jan 15 09:58:00 2024\n"
    "** TYPE: EDF_FILE BINARY EVENT SAMPLE TAGGED\n"
    "**\n"
    "\n"
    + tsv(
        "MSG|1000000 DISPLAY_COORDS 0 0 1279 1023",
        "MSG|1000000 GAZE_COORDS 0.00 0.00 1919.00 1079.00",
        "START|1000002 |RIGHT|SAMPLES|EVENTS",
        "PRESCALER|1",
        "VPRESCALER|1",
        "PUPIL|AREA",
        "EVENTS|GAZE|RIGHT|RATE| 500.00|TRACKING|CR|FILTER|2",
        "SAMPLES|GAZE|RIGHT|RATE| 500.00|TRACKING|CR|FILTER|2",
        "1000002|  640.0|  512.0| 1200.0|...",
        "1000004|  320.0|  256.0| 1210.0|...",
        "SBLINK R 1000006",
        "1000006|   .|   .|    0.0|...",
        "EBLINK R 1000006|1000006|2",
        "1000008| 1280.0| 1024.0| 1190.0|...",
        "END|1000010 |SAMPLES|EVENTS|RES|  38.00|  31.50",
    )
)
EYELINK_MIXED = "** CONVERTED FROM sub02.edf using edfapi 4.2.1\n" + tsv(
    "MSG|2000 DISPLAY_COORDS 0 0 1919 1079",
    "START|2000 |LEFT|RIGHT|SAMPLES|EVENTS",
    "SAMPLES|GAZE|LEFT|RIGHT|RATE|1000.00|TRACKING|CR|FILTER|2",
    "2000|  950.0|  530.0| 1000.0|  970.0|  550.0| 1000.0|.....",
    "2001|  480.0|  270.0| 1000.0|    .|    .|    0.0|.....",
    "2002|    .|    .|    0.0|    .|    .|    0.0|.....",
    "END|2003 |SAMPLES|EVENTS|RES|  38.00|  31.50",
    "START|3000 |LEFT|SAMPLES|EVENTS",
    "SAMPLES|GAZE|LEFT|RATE| 500.00|TRACKING|CR|FILTER|2",
    "3000|  192.0|  108.0|  900.0|...",
    "3002| 1920.0| 1080.0|  900.0|...",
    "END|3004 |SAMPLES|EVENTS|RES|  38.00|  31.50",
)
STUDIO_HEADER = (
    "ParticipantName|RecordingName|RecordingDate|RecordingResolution|MediaName|RecordingTimestamp|StudioEvent|"
    "MouseEvent|MouseEventX (ADCSpx)|MouseEventY (ADCSpx)|GazePointX (ADCSpx)|GazePointY (ADCSpx)|"
    "GazePointX (MCSpx)|GazePointY (MCSpx)|ValidityLeft|ValidityRight"
)
TOBII_STUDIO = tsv(
    STUDIO_HEADER,
    "P01|Rec 01|15.01.2024|1280 x 1024|img.jpg|0|ScreenRecStarted|||||||||",
    "P01|Rec 01|15.01.2024|1280 x 1024|img.jpg|0|||||640|512|10|10|0|0",
    "P01|Rec 01|15.01.2024|1280 x 1024|img.jpg|17||Left|100|200|||||||",
    "P01|Rec 01|15.01.2024|1280 x 1024|img.jpg|17|||||320|256|5|5|0|4",
    "P01|Rec 01|15.01.2024|1280 x 1024|img.jpg|33|||||-1|-1|-1|-1|4|4",
    "P01|Rec 01|15.01.2024|1280 x 1024|img.jpg|50|||||700|300|1|1|2|2",
)
TOBII_SDK = (
    "device_time_stamp;system_time_stamp;left_gaze_point_on_display_area;left_gaze_point_validity;"
    "left_pupil_diameter;right_gaze_point_on_display_area;right_gaze_point_validity;right_pupil_diameter\n"
    "1000;5000000;(0.4, 0.5);1;3.1;(0.6, 0.7);1;3.2\n"
    "4333;5003333;(0.25, 0.25);1;3.1;(nan, nan);0;nan\n"
    "7666;5006666;(0.9, 0.9);0;nan;(0.1, 0.1);0;nan\n"
)
PUPIL_OLD = (
    "timestamp,index,confidence,norm_pos_x,norm_pos_y,base_data,gaze_point_3d_x\n"
    "330.125,0,0.98,0.5,0.75,330.120-0 330.130-1,1.0\n"
    "330.130,0,0.97,0.25,0.5,330.126-0 330.134-1,1.0\n"
    "330.135,1,0.10,0.75,0.5,330.131-0 330.139-1,1.0\n"
)
IMOTIONS = tsv(
    "GazeTimeStamp|MediaTimeStamp|MediaFrameIndex|Gaze3dX|Gaze3dY|Gaze3dZ|Gaze2dX|Gaze2dY|PupilDiaLeft|"
    "PupilDiaRight|Confidence",
    "100.000|100.000|0|1.0|2.0|500.0|640.0|360.0|3.1|3.2|0.95",
    "100.010|100.000|0|1.0|2.0|500.0|320.0|180.0|3.1|3.2|0.99",
    "100.020|100.033|1|1.0|2.0|500.0|0.0|0.0|0.0|0.0|0.20",
)
IMOTIONS_INFO = "key,value\nRecording Name,2019_05_02\nWorld Camera Frames,402\nWorld Camera Resolution,1280x720\n"
SIMPLE = "t,x,y,confidence\n3.0,0.5,0.25,1\n3.5,,,0\n"
PUPIL_CORE = "gaze_timestamp,confidence,norm_pos_x,norm_pos_y\n50.0,0.9,0.5,0.25\n50.5,0.9,0.25,1.0\n"
PUPIL_SURFACE = "gaze_timestamp,x_norm,y_norm,on_surf\n1.0,0.5,0.25,True\n1.1,0.2,0.2,False\n"
TOBII_PRO_LAB = tsv(
    "Recording timestamp [ms]|Sensor|Gaze point X|Gaze point Y|Validity left|Validity right|"
    "Recording resolution width|Recording resolution height",
    "10|Eye Tracker|960|270|Valid|Valid|1920|1080",
    "12|Mouse|||||1920|1080",
    "18,5|Eye Tracker|480|540|Invalid|Invalid|1920|1080",
)

FIXTURES = {
    f.key: f
    for f in (
        Fixture(
            "simple",
            "trace.csv",
            SIMPLE,
            "simple",
            [0.0, 0.5],
            [True, False],
            [0.5],
            [0.25],
            invalid={"no gaze point": 1},
        ),
        Fixture("pupil", "gaze_positions.csv", PUPIL_CORE, "pupil", [0.0, 0.5], [True, True], [0.5, 0.25], [0.75, 0.0]),
        Fixture(
            "pupil_old",
            "gaze_positions.csv",
            PUPIL_OLD,
            "pupil",
            [0.0, 0.005, 0.010],
            [True, True, False],
            [0.5, 0.25],
            [0.25, 0.5],
            invalid={"below confidence 0.6": 1},
        ),
        Fixture(
            "pupil_surface",
            "gaze_positions_on_surface_Screen.csv",
            PUPIL_SURFACE,
            "pupil_surface",
            [0.0, 0.1],
            [True, False],
            [0.5],
            [0.75],
            invalid={"off the surface (on_surf False)": 1},
        ),
        Fixture(
            "tobii",
            "export.tsv",
            TOBII_PRO_LAB,
            "tobii",
            [0.0, 0.0085],
            [True, False],
            [0.5],
            [0.25],
            invalid={"both eyes Invalid": 1},
            skipped={"Sensor is not 'Eye Tracker' (mouse, gyroscope, event rows)": 1},
        ),
        Fixture(
            "pupil_imotions",
            "gaze.tlv",
            IMOTIONS,
            "pupil_imotions",
            [0.0, 0.01, 0.02],
            [True, True, False],
            [0.5, 0.25],
            [0.5, 0.25],
            siblings={"iMotions_info.csv": IMOTIONS_INFO},
            invalid={"below confidence 0.6": 1},
        ),
        Fixture(
            "neon",
            "gaze.csv",
            NEON,
            "pupil_cloud",
            [0.0, 0.005, 0.010000001, 0.015],
            [True, True, False, False],
            [0.5, 0.25],
            [0.5, 0.25],
            siblings={"info.json": NEON_INFO},
            recording="r1",
            invalid={"not worn": 1, "blink": 1},
        ),
        Fixture(
            "invisible",
            "gaze.csv",
            INVISIBLE,
            "pupil_cloud",
            [0.0, 0.004],
            [True, True],
            [0.5, 0.25],
            [0.5, 0.75],
            siblings={"info.json": INVISIBLE_INFO},
            recording="r1",
        ),
        Fixture(
            "marker_mapper",
            "gaze.csv",
            MARKER_MAPPER,
            "marker_mapper",
            [0.0, 0.005, 0.010],
            [True, False, True],
            [0.5, 0.1],
            [0.25, 0.9],
            recording="r1",
            invalid={"off the surface": 1},
        ),
        Fixture(
            "reference_image_mapper",
            "gaze.csv",
            REFERENCE_IMAGE,
            "reference_image_mapper",
            [0.0, 0.005, 0.010],
            [True, False, True],
            [0.5, 0.25],
            [0.25, 0.5],
            screen_px=(2000, 3000),
            recording="r1",
            invalid={"not in the reference image": 1},
        ),
        Fixture(
            "gazepoint",
            "User 0_all_gaze.csv",
            GAZEPOINT,
            "gazepoint",
            [0.0, 0.0166, 0.0332],
            [True, False, True],
            [0.5, 0.1],
            [0.25, 0.9],
            invalid={"flagged invalid (FPOGV 0)": 1},
        ),
        Fixture(
            "eyelink",
            "sub01.asc",
            EYELINK_MONO,
            "eyelink",
            [0.0, 0.002, 0.004, 0.006],
            [True, True, False, True],
            [0.5, 0.25, 1.0],
            [0.5, 0.25, 1.0],
            invalid={"no gaze point": 1},
            skipped={"header, message and event lines": 15},
        ),
        Fixture(
            "eyelink_mixed",
            "sub02.asc",
            EYELINK_MIXED,
            "eyelink",
            [0.0, 0.001, 0.002, 1.0, 1.002],
            [True, True, False, True, True],
            [0.5, 0.25, 0.1, 1.0],
            [0.5, 0.25, 0.1, 1.0],
            invalid={"no gaze point": 1},
            skipped={"header, message and event lines": 8},
        ),
        Fixture(
            "tobii_studio",
            "Rec 01.tsv",
            TOBII_STUDIO,
            "tobii_studio",
            [0.0, 0.017, 0.033, 0.050],
            [True, True, False, False],
            [0.5, 0.25],
            [0.5, 0.25],
            recording="Rec 01",
            invalid={"validity code 2-4 on both eyes": 2},
            skipped={"event rows (no validity codes: mouse and Studio events)": 2},
        ),
        Fixture(
            "tobii_sdk",
            "gaze_data.csv",
            TOBII_SDK,
            "tobii_sdk",
            [0.0, 0.003333, 0.006666],
            [True, True, False],
            [0.5, 0.25],
            [0.6, 0.25],
            invalid={"neither eye valid": 1},
        ),
    )
}
