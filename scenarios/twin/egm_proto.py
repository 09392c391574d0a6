"""The EGM protocol's messages (ABB's egm.proto, package abb.egm: EgmHeader, EgmRobot,
EgmSensor and their parts), built in a descriptor pool of their own so that they live beside
any other copy of egm.proto in the same process (a client's).

The serialized file descriptor below is the one `abb-robot-client` 0.4.0 ships
(abb_robot_client/_egm_protobuf/egm_pb2.py, Apache License 2.0, Copyright 2022 Wason
Technology LLC, Rensselaer Polytechnic Institute), compiled from ABB's egm.proto.
"""

from __future__ import annotations

from typing import Any

from google.protobuf import descriptor_pool, message_factory

_EGM_PROTO = (
    b'\n\tegm.proto\x12\x07abb.egm"\xeb\x01\n\tEgmHe'
    b"ader\x12\r\n\x05seqno\x18\x01 \x01(\r\x12\n\n\x02tm\x18\x02 \x01("
    b"\r\x12@\n\x05mtype\x18\x03 \x01(\x0e2\x1e.abb.egm.Egm"
    b"Header.MessageType:\x11MSGTYPE_UN"
    b'DEFINED"\x80\x01\n\x0bMessageType\x12\x15\n\x11MSG'
    b"TYPE_UNDEFINED\x10\x00\x12\x13\n\x0fMSGTYPE_CO"
    b"MMAND\x10\x01\x12\x10\n\x0cMSGTYPE_DATA\x10\x02\x12\x16\n\x12M"
    b"SGTYPE_CORRECTION\x10\x03\x12\x1b\n\x17MSGTYPE"
    b'_PATH_CORRECTION\x10\x04"/\n\x0cEgmCarte'
    b"sian\x12\t\n\x01x\x18\x01 \x02(\x01\x12\t\n\x01y\x18\x02 \x02(\x01\x12\t\n\x01"
    b'z\x18\x03 \x02(\x01"?\n\rEgmQuaternion\x12\n\n\x02u0'
    b"\x18\x01 \x02(\x01\x12\n\n\x02u1\x18\x02 \x02(\x01\x12\n\n\x02u2\x18\x03 \x02(\x01"
    b'\x12\n\n\x02u3\x18\x04 \x02(\x01"+\n\x08EgmEuler\x12\t\n\x01x\x18'
    b'\x01 \x02(\x01\x12\t\n\x01y\x18\x02 \x02(\x01\x12\t\n\x01z\x18\x03 \x02(\x01"%\n'
    b"\x08EgmClock\x12\x0b\n\x03sec\x18\x01 \x02(\x04\x12\x0c\n\x04usec"
    b'\x18\x02 \x02(\x04"w\n\x07EgmPose\x12"\n\x03pos\x18\x01 \x01(\x0b'
    b"2\x15.abb.egm.EgmCartesian\x12&\n\x06ori"
    b"ent\x18\x02 \x01(\x0b2\x16.abb.egm.EgmQuatern"
    b"ion\x12 \n\x05euler\x18\x03 \x01(\x0b2\x11.abb.egm.E"
    b'gmEuler""\n\x11EgmCartesianSpeed\x12\r'
    b'\n\x05value\x18\x01 \x03(\x01"\x1b\n\tEgmJoints\x12\x0e\n\x06'
    b'joints\x18\x01 \x03(\x01"#\n\x11EgmExternalJoi'
    b'nts\x12\x0e\n\x06joints\x18\x01 \x03(\x01"\xa2\x01\n\nEgmPla'
    b'nned\x12"\n\x06joints\x18\x01 \x01(\x0b2\x12.abb.egm'
    b".EgmJoints\x12#\n\tcartesian\x18\x02 \x01(\x0b2"
    b"\x10.abb.egm.EgmPose\x12*\n\x0eexternalJ"
    b"oints\x18\x03 \x01(\x0b2\x12.abb.egm.EgmJoint"
    b"s\x12\x1f\n\x04time\x18\x04 \x01(\x0b2\x11.abb.egm.EgmC"
    b'lock"\x8d\x01\n\x0bEgmSpeedRef\x12"\n\x06joints'
    b"\x18\x01 \x01(\x0b2\x12.abb.egm.EgmJoints\x12.\n\n"
    b"cartesians\x18\x02 \x01(\x0b2\x1a.abb.egm.Egm"
    b"CartesianSpeed\x12*\n\x0eexternalJoin"
    b'ts\x18\x03 \x01(\x0b2\x12.abb.egm.EgmJoints">'
    b'\n\x0bEgmPathCorr\x12"\n\x03pos\x18\x01 \x02(\x0b2\x15.a'
    b"bb.egm.EgmCartesian\x12\x0b\n\x03age\x18\x02 \x02"
    b'(\r"\xa3\x01\n\x0bEgmFeedBack\x12"\n\x06joints\x18\x01'
    b" \x01(\x0b2\x12.abb.egm.EgmJoints\x12#\n\tca"
    b"rtesian\x18\x02 \x01(\x0b2\x10.abb.egm.EgmPos"
    b"e\x12*\n\x0eexternalJoints\x18\x03 \x01(\x0b2\x12.ab"
    b"b.egm.EgmJoints\x12\x1f\n\x04time\x18\x04 \x01(\x0b2"
    b'\x11.abb.egm.EgmClock"\x8c\x01\n\rEgmMoto'
    b"rState\x124\n\x05state\x18\x01 \x02(\x0e2%.abb.eg"
    b"m.EgmMotorState.MotorStateType"
    b'"E\n\x0eMotorStateType\x12\x14\n\x10MOTORS_U'
    b"NDEFINED\x10\x00\x12\r\n\tMOTORS_ON\x10\x01\x12\x0e\n\nM"
    b'OTORS_OFF\x10\x02"\xa2\x01\n\x0bEgmMCIState\x12?\n'
    b"\x05state\x18\x01 \x02(\x0e2!.abb.egm.EgmMCIS"
    b"tate.MCIStateType:\rMCI_UNDEFIN"
    b'ED"R\n\x0cMCIStateType\x12\x11\n\rMCI_UNDE'
    b"FINED\x10\x00\x12\r\n\tMCI_ERROR\x10\x01\x12\x0f\n\x0bMCI_"
    b'STOPPED\x10\x02\x12\x0f\n\x0bMCI_RUNNING\x10\x03"\xc3\x01\n'
    b"\x15EgmRapidCtrlExecState\x12U\n\x05stat"
    b"e\x18\x01 \x02(\x0e25.abb.egm.EgmRapidCtrl"
    b"ExecState.RapidCtrlExecStateTy"
    b'pe:\x0fRAPID_UNDEFINED"S\n\x16RapidCt'
    b"rlExecStateType\x12\x13\n\x0fRAPID_UNDEF"
    b"INED\x10\x00\x12\x11\n\rRAPID_STOPPED\x10\x01\x12\x11\n\rR"
    b'APID_RUNNING\x10\x02"!\n\x0eEgmTestSigna'
    b'ls\x12\x0f\n\x07signals\x18\x01 \x03(\x01"3\n\x10EgmMeas'
    b"uredForce\x12\x10\n\x08fcActive\x18\x01 \x01(\x08\x12\r\n"
    b'\x05force\x18\x02 \x03(\x01"C\n\x10EgmCollisionIn'
    b"fo\x12\x19\n\x11collsionTriggered\x18\x01 \x01(\x08\x12"
    b'\x14\n\x0ccollDetQuota\x18\x02 \x03(\x01",\n\x0cEgmRA'
    b"PIDdata\x12\x0e\n\x06digVal\x18\x01 \x01(\x08\x12\x0c\n\x04dnu"
    b'm\x18\x02 \x03(\x01"\x90\x04\n\x08EgmRobot\x12"\n\x06header'
    b"\x18\x01 \x01(\x0b2\x12.abb.egm.EgmHeader\x12&\n\x08"
    b"feedBack\x18\x02 \x01(\x0b2\x14.abb.egm.EgmFe"
    b"edBack\x12$\n\x07planned\x18\x03 \x01(\x0b2\x13.abb."
    b"egm.EgmPlanned\x12*\n\nmotorState\x18\x04"
    b" \x01(\x0b2\x16.abb.egm.EgmMotorState\x12&"
    b"\n\x08mciState\x18\x05 \x01(\x0b2\x14.abb.egm.Egm"
    b"MCIState\x12\x19\n\x11mciConvergenceMet\x18"
    b"\x06 \x01(\x08\x12,\n\x0btestSignals\x18\x07 \x01(\x0b2\x17.a"
    b"bb.egm.EgmTestSignals\x126\n\x0erapid"
    b"ExecState\x18\x08 \x01(\x0b2\x1e.abb.egm.EgmR"
    b"apidCtrlExecState\x120\n\rmeasuredF"
    b"orce\x18\t \x01(\x0b2\x19.abb.egm.EgmMeasur"
    b"edForce\x12\x17\n\x0futilizationRate\x18\n \x01"
    b"(\x01\x12\x11\n\tmoveIndex\x18\x0b \x01(\r\x120\n\rColli"
    b"sionInfo\x18\x0c \x01(\x0b2\x19.abb.egm.EgmCo"
    b"llisionInfo\x12-\n\x0eRAPIDfromRobot\x18"
    b'\r \x01(\x0b2\x15.abb.egm.EgmRAPIDdata"\xaa'
    b'\x01\n\tEgmSensor\x12"\n\x06header\x18\x01 \x01(\x0b2\x12'
    b".abb.egm.EgmHeader\x12$\n\x07planned\x18"
    b"\x02 \x01(\x0b2\x13.abb.egm.EgmPlanned\x12&\n\x08"
    b"speedRef\x18\x03 \x01(\x0b2\x14.abb.egm.EgmSp"
    b"eedRef\x12+\n\x0cRAPIDtoRobot\x18\x04 \x01(\x0b2\x15"
    b'.abb.egm.EgmRAPIDdata"_\n\x11EgmSe'
    b'nsorPathCorr\x12"\n\x06header\x18\x01 \x01(\x0b2\x12'
    b".abb.egm.EgmHeader\x12&\n\x08pathCorr"
    b"\x18\x02 \x01(\x0b2\x14.abb.egm.EgmPathCorr"
)

_POOL = descriptor_pool.DescriptorPool()
_POOL.AddSerializedFile(_EGM_PROTO)


def message(name: str) -> Any:
    """The message class `abb.egm.<name>` (e.g. "EgmRobot")."""
    return message_factory.GetMessageClass(_POOL.FindMessageTypeByName(f"abb.egm.{name}"))


EgmRobot = message("EgmRobot")
EgmSensor = message("EgmSensor")
EgmHeader = message("EgmHeader")
