"""What RAPID's instructions are to this project: which move the arm and how.

The reader parses every instruction the grammar allows, whatever its name; this catalogue only
says what an instruction is, so that a procedure called but defined nowhere can be told from a
RAPID instruction, and a motion instruction the executor does not model can be refused:

- `MODELLED_MOVES`: the moves the reader resolves to targets (`scenarios.rapid.module.MOVES`
  gives their arguments); the executor runs MoveJ, MoveL and MoveAbsJ of them.
- `is_motion(name)`: an instruction that moves the arm or changes its path (a move, a search,
  a triggered or process move, path and offset control, independent axes, external guidance).
- `KNOWN`: the RAPID instructions (RobotWare 6 and 7 Instructions reference, the options most
  backups use) that are not motion; called without a PROC of that name in the task, they are
  kept as opaque statements.

Names compare case-insensitively (RAPID's names do).
"""

from __future__ import annotations

import re

from scenarios.rapid.module import MOVES


def _words(text: str) -> frozenset[str]:
    return frozenset(text.casefold().split())


#: The moves the reader resolves (target, speed, zone, tool, \WObj).
MODELLED_MOVES = frozenset(MOVES)

# Instructions that move the arm or change its path, besides every Move*, Search* and
# Trigg[JLC]* (by prefix, below).
_MOTION = _words(
    "StopMove StartMove StartMoveRetry StopMoveReset ClearPath StorePath RestoPath "
    "PathRecStart PathRecStop PathRecMoveBwd PathRecMoveFwd "
    "PDispOn PDispSet EOffsOn EOffsSet CorrCon CorrWrite CorrClear CorrDiscon "
    "SyncMoveOn SyncMoveOff SyncMoveResume SyncMoveSuspend SyncMoveUndo "
    "ActUnit DeactUnit SoftAct SoftDeact IndAMove IndCMove IndDMove IndRMove IndReset "
    "ArcL ArcC ArcL1 ArcC1 ArcL2 ArcC2 ArcLStart ArcLEnd ArcCStart ArcCEnd ArcMoveJ "
    "ArcMoveL ArcMoveAbsJ ArcRepL ArcMoveExtJ "
    "SpotL SpotJ SpotML SpotMJ CapL CapC PaintL PaintC DispL DispC "
    "EGMRunJoint EGMRunPose EGMMoveL EGMMoveC ContactL CSSAct CSSDeact CSSDeactMoveL "
    "SyncToSensor StepBwdPath "
    "SetLeadThrough WaitWObj DropWObj"
)
_MOTION_PREFIX = re.compile(r"^(move|search|trigg[jlc]|arc[lc]|spot|cap[lc])", re.IGNORECASE)

#: RAPID instructions that do not move the arm (I/O, messages, data, files, sockets,
#: interrupts, errors, loading, system data, waits, settings the executor honours or skips).
KNOWN = _words(
    # settings of motion the executor honours or that do not change the path
    "AccSet VelSet ConfJ ConfL SingArea PathResol CirPathMode GripLoad MechUnitLoad "
    "PathAccLim ResetAxisMoveTime ResetAxisDistance "
    "PDispOff EOffsOff TuneReset TuneServo WorldAccLim MotionSup SpeedRefresh SpeedLimAxis "
    "SpeedLimCheckPoint SafetyControllerSyncRequest SetSysData "
    # waits
    "WaitTime WaitDI WaitDO WaitAI WaitAO WaitGI WaitGO WaitUntil WaitRob WaitSyncTask "
    "WaitLoad WaitTestAndSet WaitAnyDI "
    # I/O
    "Set Reset SetDO SetAO SetGO PulseDO InvertDO IODisable IOEnable IODeactivate IOActivate "
    "AliasIO BitSet BitClear "
    "SetDataSearch GetDataVal SetDataVal SetAllDataVal GetNextSym "
    # messages and the FlexPendant
    "TPWrite TPErase TPReadFK TPReadNum TPReadDnum TPShow ErrWrite ErrLog UIMsgBox UIShow "
    "TextTabInstall ElogWrite "
    # program flow and data
    "Stop Exit ExitCycle Break Incr Decr Add Clear ProcCall CallByVar SkipWarn RaiseToUser "
    "ErrRaise BookErrNo ResetRetryCount ReadErrData ClkReset ClkStart ClkStop "
    "ProcerrRecovery GetTrapData MToolRotCalib MToolTCPCalib SToolRotCalib SToolTCPCalib "
    "SpyStart SpyStop SetupCyclicBool RemoveCyclicBool CopyRawBytes ClearRawBytes "
    "PackRawBytes UnpackRawBytes PackDNHeader ReadRawBytes WriteRawBytes StrToVal "
    "TestSignDefine TestSignReset IDelete ISignalDI ISignalDO ISignalAI ISignalAO "
    "ISignalGI ISignalGO ITimer ISleep IWatch IEnable IDisable IError IPers IVarValue IRMQMessage "
    "CONNECT "
    # files and sockets
    "Open Close Write WriteBin WriteStrBin WriteAnyBin ReadAnyBin WriteBlock ReadBlock Rewind "
    "ClearIOBuff OpenDir CloseDir MakeDir RemoveDir RemoveFile RenameFile CopyFile "
    "SocketCreate SocketConnect SocketSend SocketReceive SocketReceiveFrom SocketSendTo "
    "SocketClose SocketBind SocketListen SocketAccept "
    "RMQFindSlot RMQSendMessage RMQGetMessage RMQGetMsgData RMQGetMsgHeader RMQReadWait "
    "RMQEmptyQueue SCWrite "
    # modules, configuration, system
    "Load UnLoad StartLoad EraseModule Save ReadCfgData WriteCfgData WarmStart GetSysData "
    "SetSysData SiConnect SiClose SiGetCyclic SiSetCyclic "
    # external guided motion setup and streaming (EGMRun*/EGMMove* move the arm)
    "EGMActJoint EGMActPose EGMActMove EGMGetId EGMReset EGMSetupAI EGMSetupAO EGMSetupGI "
    "EGMSetupLTAPP EGMSetupUC EGMStreamStart EGMStreamStop EGMStop "
    # triggers set up for a later triggered move
    "TriggIO TriggEquip TriggInt TriggCheckIO TriggSpeed TriggStopProc TriggRampAO TriggDataCopy "
    "TriggDataReset TriggDataValid "
    # world zones
    "WZBoxDef WZCylDef WZSphDef WZHomeJointDef WZLimJointDef WZLimSup WZDOSet WZEnable "
    "WZDisable WZFree"
)


def is_motion(name: str) -> bool:
    """An instruction that moves the arm or changes its path (see the module's docstring)."""
    key = name.casefold()
    if key in KNOWN:
        return False
    return key in _MOTION or key in MODELLED_MOVES or _MOTION_PREFIX.match(key) is not None


def is_instruction(name: str) -> bool:
    """A RAPID instruction this catalogue knows (motion or not)."""
    return name.casefold() in KNOWN or is_motion(name)
