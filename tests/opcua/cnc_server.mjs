// An independent OPC UA server for volcal's capture tests: node-opcua (npm) loading the
// official OPC 40502 CNC information model (Opc.Ua.CNC.NodeSet.xml, shipped in npm
// node-opcua-nodesets), with three axes X, Y, Z (or those of axes=) instantiated from
// CncAxisType under Objects/CncInterface/CncAxisList. The test writes positions on request.
//
// Usage: node cnc_server.mjs PORT [secure PKI_FOLDER] [axes=SPEC,...] [channel]
//        [channels=NAME,...] [unreadable]
// With "channel", one CncChannelType object (Objects/CncInterface/CncChannelList/Channel1)
// whose ActProgramStatus (CncChannelProgramStatus: Stopped 0, Running 1, Waiting 2,
// Interrupted 3, Canceled 4) starts Stopped and is written by {"program": N}; with
// "channels=", those channels ({"program": N, "channel": NAME}; default the first); with
// "unreadable", their ActProgramStatus has no read access (a server that lists it only).
// With "secure", the server offers only signed and encrypted channels (Basic256Sha256,
// SignAndEncrypt), keeps its certificates in PKI_FOLDER and accepts any client certificate.
// With "axes=", the axes instantiated (default X,Y,Z), each NAME or NAME:UNIT, as a CNC
// exposes them under OPC 40502: NAME alone a linear axis as the defaults (IsRotational
// false, no EngineeringUnits: the model's mm); NAME:mm a linear axis in millimetres
// (UNECE MMT); NAME:deg a rotary axis in degrees (IsRotational true, UNECE DD), NAME:rad
// in radians (C81), NAME:rot a rotary axis without EngineeringUnits. The units are set on
// PosDirect's and PosIndirect's EngineeringUnits property (CncPositionVariableType).
// Prints one line "READY opc.tcp://127.0.0.1:PORT/ NSURI" on stdout once it serves, then
// reads one JSON command per line on stdin:
//   {"set": {"X": 10.0, "Y": 0.0}}   write PosDirect.ActPos (and the PosDirect structure)
//   {"add": ["C:deg"]}                instantiate axes (as axes=), at position 0
//   {"remove": ["C"]}                 delete axes (a client browsing afterwards sees none)
//   {"program": 3}                    write the channel's ActProgramStatus (with "channel")
//   {"program": 3, "channel": "C2"}   the same, of the channel named C2 ("channels=")
//   {"quit": true}                    shut down (closing stdin does the same)
// and answers each other command with "OK <n>" (n: the count of commands served).
// Only loopback: the endpoint is bound to 127.0.0.1.

import readline from "node:readline";
import {
  OPCUAServer, OPCUACertificateManager, DataType, MessageSecurityMode, SecurityPolicy,
  makeEUInformation,
} from "node-opcua";
import { nodesets } from "node-opcua-nodesets";

const port = Number(process.argv[2] || 4840);
const CNC_URI = "http://opcfoundation.org/UA/CNC";

const secure = process.argv[3] === "secure";
const axesArg = process.argv.slice(3).find((a) => a.startsWith("axes="));
function axisSpec(a) {
  const [name, unit = ""] = a.split(":");
  if (!["", "mm", "deg", "rad", "rot"].includes(unit)) {
    throw new Error(`axis ${a}: unit ${unit} is not one of mm, deg, rad, rot`);
  }
  return { name, unit };
}
const axisSpecs = (axesArg ? axesArg.slice(5) : "X,Y,Z").split(",").map(axisSpec);
// UNECE Rec. 20 common codes of the units (EUInformation.unitId is the code's bytes)
const UNITS = {
  mm: makeEUInformation("MMT", "mm", "millimetre"),
  deg: makeEUInformation("DD", "°", "degree [unit of angle]"),
  rad: makeEUInformation("C81", "rad", "radian"),
};
const security = secure ? {
  securityModes: [MessageSecurityMode.SignAndEncrypt],
  securityPolicies: [SecurityPolicy.Basic256Sha256],
  serverCertificateManager: new OPCUACertificateManager({
    rootFolder: process.argv[4], automaticallyAcceptUnknownCertificate: true,
  }),
} : {
  securityModes: [MessageSecurityMode.None],
  securityPolicies: [SecurityPolicy.None],
};

const server = new OPCUAServer({
  port,
  hostname: "127.0.0.1",
  alternateHostname: [],
  nodeset_filename: [nodesets.standard, nodesets.cnc],
  ...security,
  allowAnonymous: true,
  disableDiscovery: true,
  buildInfo: { productName: "volcal-test-cnc", buildNumber: "1" },
});

await server.initialize();
const addressSpace = server.engine.addressSpace;
const nsCnc = addressSpace.getNamespaceIndex(CNC_URI);
if (nsCnc < 0) {
  throw new Error(`the CNC nodeset did not load: no namespace ${CNC_URI}`);
}
const axisType = addressSpace.findObjectType("CncAxisType", nsCnc);
const own = addressSpace.getOwnNamespace();
const iface = own.addObject({
  browseName: "CncInterface",
  organizedBy: addressSpace.rootFolder.objects,
});
const axisList = own.addObject({ browseName: "CncAxisList", componentOf: iface });

const axes = {};
for (const { name, unit } of axisSpecs) {
  add(name, unit);
}

const programStatus = {};
const channelsArg = process.argv.slice(3).find((a) => a.startsWith("channels="));
const channelNames = channelsArg ? channelsArg.slice(9).split(",")
  : (process.argv.slice(3).includes("channel") ? ["Channel1"] : []);
if (channelNames.length) {
  const channelType = addressSpace.findObjectType("CncChannelType", nsCnc);
  const channelList = own.addObject({ browseName: "CncChannelList", componentOf: iface });
  for (const name of channelNames) {
    const channel = channelType.instantiate({ browseName: name, componentOf: channelList });
    programStatus[name] = channel.getComponentByName("ActProgramStatus", nsCnc);
    setProgram(0, name);
    if (process.argv.slice(3).includes("unreadable")) {
      // a server that exposes the status without letting it be read (BadNotReadable)
      programStatus[name].accessLevel = 0;
      programStatus[name].userAccessLevel = 0;
    }
  }
}

function setProgram(value, name) {
  const node = programStatus[name || channelNames[0]];
  if (!node) {
    throw new Error(`no channel ${name || ""} (start the server with channel or channels=)`);
  }
  node.setValueFromSource({ dataType: DataType.Int32, value });
}

function add(name, unit) {
  if (axes[name]) {
    throw new Error(`axis ${name} exists`);
  }
  const axis = axisType.instantiate({ browseName: name, componentOf: axisList });
  const posDirect = axis.getComponentByName("PosDirect", nsCnc);
  const actPos = posDirect.getComponentByName("ActPos", nsCnc);
  const cmdPos = posDirect.getComponentByName("CmdPos", nsCnc);
  if (unit) {
    describe(axis, unit);
  }
  axes[name] = { axis, posDirect, actPos, cmdPos };
  set(name, 0.0);
}

function remove(name) {
  if (!axes[name]) {
    throw new Error(`no axis ${name}`);
  }
  addressSpace.deleteNode(axes[name].axis);
  delete axes[name];
}

function describe(axis, unit) {
  // IsRotational (a mandatory component of CncAxisType) and the positions' units
  const rotary = unit !== "mm";
  axis.getComponentByName("IsRotational", nsCnc)
    .setValueFromSource({ dataType: DataType.Boolean, value: rotary });
  if (!UNITS[unit]) {
    return; // "rot": a rotary axis whose positions carry no EngineeringUnits
  }
  for (const pos of ["PosDirect", "PosIndirect"]) {
    const eu = axis.getComponentByName(pos, nsCnc).getPropertyByName("EngineeringUnits", nsCnc);
    eu.setValueFromSource({ dataType: DataType.ExtensionObject, value: UNITS[unit] });
  }
}

function set(name, value) {
  const a = axes[name];
  if (!a) {
    throw new Error(`no axis ${name}`);
  }
  a.actPos.setValueFromSource({ dataType: DataType.Double, value });
  a.cmdPos.setValueFromSource({ dataType: DataType.Double, value });
  try {
    const ext = addressSpace.constructExtensionObject(a.posDirect.dataType,
      { actPos: value, cmdPos: value, remDist: 0.0 });
    a.posDirect.setValueFromSource({ dataType: DataType.ExtensionObject, value: ext });
  } catch (err) {
    // the structure is a convenience for other clients; ActPos is what the test reads
  }
}

await server.start();
process.stdout.write(`READY opc.tcp://127.0.0.1:${port}/ ${CNC_URI}\n`);

let served = 0;
let stopping = false;
async function stop() {
  if (stopping) return;
  stopping = true;
  await server.shutdown(0);
  process.exit(0);
}

const rl = readline.createInterface({ input: process.stdin });
rl.on("line", (line) => {
  line = line.trim();
  if (!line) return;
  let cmd;
  try {
    cmd = JSON.parse(line);
  } catch (err) {
    process.stdout.write(`ERROR not JSON: ${line}\n`);
    return;
  }
  if (cmd.quit) {
    stop();
    return;
  }
  try {
    for (const a of cmd.add || []) {
      const { name, unit } = axisSpec(a);
      add(name, unit);
    }
    for (const name of cmd.remove || []) {
      remove(name);
    }
    for (const [name, value] of Object.entries(cmd.set || {})) {
      set(name, Number(value));
    }
    if (cmd.program !== undefined) {
      setProgram(Number(cmd.program), cmd.channel);
    }
    served += 1;
    process.stdout.write(`OK ${served}\n`);
  } catch (err) {
    process.stdout.write(`ERROR ${err.message}\n`);
  }
});
rl.on("close", stop);
process.on("SIGTERM", stop);
