// An independent OPC UA server for volcal's capture tests: node-opcua (npm) loading the
// official OPC 40502 CNC information model (Opc.Ua.CNC.NodeSet.xml, shipped in npm
// node-opcua-nodesets), with three axes X, Y, Z instantiated from CncAxisType under
// Objects/CncInterface/CncAxisList. The test writes positions on request.
//
// Usage: node cnc_server.mjs PORT [secure PKI_FOLDER]
// With "secure", the server offers only signed and encrypted channels (Basic256Sha256,
// SignAndEncrypt), keeps its certificates in PKI_FOLDER and accepts any client certificate.
// Prints one line "READY opc.tcp://127.0.0.1:PORT/ NSURI" on stdout once it serves, then
// reads one JSON command per line on stdin:
//   {"set": {"X": 10.0, "Y": 0.0}}   write PosDirect.ActPos (and the PosDirect structure)
//   {"quit": true}                    shut down (closing stdin does the same)
// and answers each "set" with "OK <n>" (n: the count of commands served).
// Only loopback: the endpoint is bound to 127.0.0.1.

import readline from "node:readline";
import {
  OPCUAServer, OPCUACertificateManager, DataType, MessageSecurityMode, SecurityPolicy,
} from "node-opcua";
import { nodesets } from "node-opcua-nodesets";

const port = Number(process.argv[2] || 4840);
const CNC_URI = "http://opcfoundation.org/UA/CNC";

const secure = process.argv[3] === "secure";
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
for (const name of ["X", "Y", "Z"]) {
  const axis = axisType.instantiate({ browseName: name, componentOf: axisList });
  const posDirect = axis.getComponentByName("PosDirect", nsCnc);
  const actPos = posDirect.getComponentByName("ActPos", nsCnc);
  const cmdPos = posDirect.getComponentByName("CmdPos", nsCnc);
  axes[name] = { axis, posDirect, actPos, cmdPos };
  set(name, 0.0);
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
    for (const [name, value] of Object.entries(cmd.set || {})) {
      set(name, Number(value));
    }
    served += 1;
    process.stdout.write(`OK ${served}\n`);
  } catch (err) {
    process.stdout.write(`ERROR ${err.message}\n`);
  }
});
rl.on("close", stop);
process.on("SIGTERM", stop);
