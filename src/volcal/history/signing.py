"""Signed records: an Ed25519 signature of every record's hash (optional, for laboratories).

The hash chain (:mod:`volcal.history.chain`) shows a change made by someone who did not
recompute the hashes; anyone with write access to the database can recompute them. With a
private key configured, every appended record's hash is signed, and the signature is stored
beside the record (``records.signature``, ``records.key_id``; schema revision ``0003``). As
each hash covers its predecessor's, a valid signature on a record vouches for every record
up to it. :func:`check_signatures` (``volcal history verify --public-key FILE``) then finds a
record rewritten with recomputed hashes (its signature, or the next signed one's, no longer
matches) and a record appended without the private key (unsigned, or signed by another key).

The key pair is written by :func:`new_key_pair` (``volcal history key new``): PEM files,
the private key (PKCS #8, not encrypted) with permissions 0600, written atomically.
Key handling is documented in ``docs/history.md``, "Signed records".
"""

from __future__ import annotations

import hashlib
import os
import stat
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError

KEY_ENV = "VOLCAL_HISTORY_KEY"
"""Environment variable naming the private key file (``--private-key`` wins over it)."""
PRIVATE_NAME = "history-key.pem"
PUBLIC_NAME = "history-key.pub.pem"
_DOMAIN = b"volcal-history-record-v1\n"
"""Prefix of every signed message: a signature of a record cannot be taken for another use."""


def _crypto() -> Any:
    """The ``cryptography`` package, or a clear error naming the extra to install."""
    try:
        from cryptography.hazmat.primitives.asymmetric import ed25519
    except ImportError:
        from volcal.extras import MissingExtraError

        raise MissingExtraError("signed history records", "history", ["cryptography"]) \
            from None
    return ed25519


def default_key_folder() -> Path:
    """Where ``volcal history key new`` writes without ``-o``.

    ``$XDG_CONFIG_HOME/volcal``, else ``~/.config/volcal``.
    """
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "volcal"


def message(record_hash: str) -> bytes:
    """The bytes signed for a record: a fixed prefix and the record's hash (64 hex digits).

    Parameters
    ----------
    record_hash : str
        The record's hash (:func:`volcal.history.chain.record_hash`).
    """
    return _DOMAIN + record_hash.encode("ascii")


def key_id(public_key: Any) -> str:
    """Short fingerprint of a public key.

    The first 16 hex digits of the sha256 of its 32 raw bytes.

    Parameters
    ----------
    public_key : Ed25519PublicKey
    """
    from cryptography.hazmat.primitives import serialization as ser

    raw = public_key.public_bytes(ser.Encoding.Raw, ser.PublicFormat.Raw)
    return hashlib.sha256(raw).hexdigest()[:16]


def _write_private(path: Path, data: bytes) -> None:
    """Write ``data`` atomically into a file that is 0600 from its creation."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        if hasattr(os, "fchmod"):  # POSIX: mkstemp's mode already; said again
            os.fchmod(fd, 0o600)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def new_key_pair(folder: str | Path | None = None) -> tuple[Path, Path, str]:
    """Make an Ed25519 key pair.

    ``history-key.pem`` (private, 0600) and ``history-key.pub.pem`` (public) in ``folder``.

    Parameters
    ----------
    folder : str or Path, optional
        Folder to write into (created 0700 when missing); default
        :func:`default_key_folder`.

    Returns
    -------
    private, public : Path
        The files written.
    kid : str
        The key id (:func:`key_id`).

    Raises
    ------
    VolcalInputError
        A key file is already there (a private key is never overwritten).
    """
    from cryptography.hazmat.primitives import serialization as ser

    ed25519 = _crypto()
    folder = Path(folder) if folder is not None else default_key_folder()
    private, public = folder / PRIVATE_NAME, folder / PUBLIC_NAME
    for p in (private, public):
        if p.exists():
            raise VolcalInputError("a key is already there: a key pair is never "
                                   "overwritten (move it away, or choose another folder "
                                   "with -o)", p)
    try:
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
    except OSError as exc:
        raise VolcalInputError(f"cannot create the key folder ({exc.strerror})", folder) \
            from None
    key = ed25519.Ed25519PrivateKey.generate()
    pem = key.private_bytes(ser.Encoding.PEM, ser.PrivateFormat.PKCS8, ser.NoEncryption())
    pub = key.public_key().public_bytes(ser.Encoding.PEM,
                                        ser.PublicFormat.SubjectPublicKeyInfo)
    from volcal.io.atomic import write_bytes

    _write_private(private, pem)
    write_bytes(public, pub)
    return private, public, key_id(key.public_key())


def _read_key_file(path: Path, what: str) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise VolcalInputError(f"{what} file not found", path) from None
    except OSError as exc:
        raise VolcalInputError(f"cannot read the {what} file ({exc.strerror})", path) \
            from None


class Signer:
    """Signs record hashes with a private key file.

    Parameters
    ----------
    path : str or Path
        PEM file of an Ed25519 private key (``volcal history key new``), not readable by
        the group or others.

    Raises
    ------
    VolcalInputError
        Missing file, permissions open to others, not an Ed25519 private key.
    """

    def __init__(self, path: str | Path) -> None:
        from cryptography.hazmat.primitives import serialization as ser

        ed25519 = _crypto()
        self.path = Path(path)
        data = _read_key_file(self.path, "private key")
        mode = stat.S_IMODE(self.path.stat().st_mode)
        if os.name == "posix" and mode & 0o077:
            raise VolcalInputError(f"the private key is readable by others (permissions "
                                   f"{mode:04o}): chmod 600 it", self.path)
        try:
            key = ser.load_pem_private_key(data, password=None)
        except (ValueError, TypeError) as exc:
            raise VolcalInputError(f"not a usable private key ({exc})", self.path) from None
        if not isinstance(key, ed25519.Ed25519PrivateKey):
            raise VolcalInputError("not an Ed25519 private key (volcal history key new "
                                   "makes one)", self.path)
        self._key = key
        self.key_id = key_id(key.public_key())

    def sign(self, record_hash: str) -> str:
        """The signature of a record's hash, 128 hex digits.

        Parameters
        ----------
        record_hash : str
            The record's hash.
        """
        return self._key.sign(message(record_hash)).hex()


def signer_from(private_key: str | Path | None) -> Signer | None:
    """The signer of a store.

    ``private_key`` if given, else the file named by ``VOLCAL_HISTORY_KEY``, else none
    (records unsigned).

    Parameters
    ----------
    private_key : str or Path, optional
        Private key file (``--private-key``).
    """
    chosen = private_key if private_key not in (None, "") else os.environ.get(KEY_ENV)
    return Signer(chosen) if chosen else None


def load_public_key(path: str | Path) -> tuple[Any, str]:
    """An Ed25519 public key from a PEM file, with its key id.

    Parameters
    ----------
    path : str or Path
        ``history-key.pub.pem`` (or any PEM SubjectPublicKeyInfo of an Ed25519 key).

    Raises
    ------
    VolcalInputError
        Missing file, not an Ed25519 public key.
    """
    from cryptography.hazmat.primitives import serialization as ser

    ed25519 = _crypto()
    path = Path(path)
    data = _read_key_file(path, "public key")
    try:
        key = ser.load_pem_public_key(data)
    except (ValueError, TypeError) as exc:
        raise VolcalInputError(f"not a usable public key ({exc})", path) from None
    if not isinstance(key, ed25519.Ed25519PublicKey):
        raise VolcalInputError("not an Ed25519 public key (volcal history key new makes "
                               "one)", path)
    return key, key_id(key)


@dataclass
class SignatureCheck:
    """What :func:`check_signatures` found.

    Attributes
    ----------
    ok : bool
        Every record is covered by a valid signature of one of the keys.
    first_bad : str or None
        The first record that fails (``C000004 (record 4)``).
    why : str
        What is wrong with it.
    signed : int
        Records carrying a valid signature.
    n : int
        Records checked.
    last_signed : str or None
        The last record with a valid signature.
    """

    ok: bool
    first_bad: str | None
    why: str
    signed: int
    n: int
    last_signed: str | None


def check_signatures(rows: list[dict[str, Any]], public_keys: list[tuple[Any, str]]
                     ) -> SignatureCheck:
    """Check the signature of every record against the public keys.

    A record signed by one of the keys vouches, through the chain, for every record before
    it; records before the first signed one (kept before signing began) are accepted
    unsigned. Refused: a signature that does not match its record's hash (a rewritten
    record, whatever hashes were recomputed), a signature by a key not given, and an
    unsigned record after a signed one (an append without the private key), or no signed
    record at all. The chain itself (links, hashes) is :meth:`Store.verify`'s.

    Parameters
    ----------
    rows : list of dict
        ``seq, id, hash, signature, key_id`` of every record, in chain order.
    public_keys : list of (Ed25519PublicKey, str)
        The keys accepted and their ids (:func:`load_public_key`).

    Returns
    -------
    SignatureCheck
    """
    from cryptography.exceptions import InvalidSignature

    keys = dict((kid, k) for k, kid in public_keys)
    given = ", ".join(sorted(keys))
    signed, last = 0, None
    for r in rows:
        label = f"{r['id']} (record {r['seq']})"
        sig = r.get("signature")
        if not sig:
            if last is not None:
                return SignatureCheck(False, label, f"it is not signed, after signed "
                                      f"records (last signed: {last})", signed, len(rows),
                                      last)
            continue
        kid = r.get("key_id")
        key = keys.get(kid) if isinstance(kid, str) else None
        if key is None:
            return SignatureCheck(False, label, f"signed by key {kid}, not by "
                                  f"the key given ({given})", signed, len(rows), last)
        try:
            key.verify(bytes.fromhex(sig), message(r["hash"]))
        except (InvalidSignature, ValueError, TypeError):  # also no hex, not text
            return SignatureCheck(False, label, "its signature does not match its hash "
                                  f"under key {r.get('key_id')}", signed, len(rows), last)
        signed, last = signed + 1, label
    if last is None:
        return SignatureCheck(False, None, "no record is signed", 0, len(rows), None)
    return SignatureCheck(True, None, "", signed, len(rows), last)


def verify_store(store: Any, public_keys: list[tuple[Any, str]]) -> SignatureCheck:
    """:func:`check_signatures` over every record of a store (one query, no children).

    Parameters
    ----------
    store : Store
        The history store.
    public_keys : list of (Ed25519PublicKey, str)
        The keys accepted (:func:`load_public_key`).
    """
    from sqlalchemy import select

    from volcal.history import schema as t

    c = t.records.c
    with store.engine.connect() as conn:
        rows = [dict(r) for r in conn.execute(select(c.seq, c.id, c.hash, c.signature,
                                                     c.key_id).order_by(c.seq)).mappings()]
    return check_signatures(rows, public_keys)
